// What every browser render check does with a view it rendered: compares it texel by texel with
// loom's own rendering of the same view, and writes it as loom writes its own (a PNG at the view's
// white, RGB floats).

function srgb8(linear) {
  const v = Math.min(Math.max(linear, 0), 1);
  return Math.round(255 * (v <= 0.0031308 ? 12.92 * v : 1.055 * Math.pow(v, 1 / 2.4) - 0.055));
}

// RGBA floats (row 0 = the maps' first row) as a PNG at white = `white`, as loom writes its own.
export function pngOf(rgba, width, height, white) {
  const canvas = document.createElement('canvas');
  canvas.width = width;
  canvas.height = height;
  const context = canvas.getContext('2d');
  const image = context.createImageData(width, height);
  for (let i = 0; i < width * height; ++i) {
    for (let c = 0; c < 3; ++c) image.data[4 * i + c] = srgb8(rgba[4 * i + c] / white);
    image.data[4 * i + 3] = 255;
  }
  context.putImageData(image, 0, 0);
  return canvas.toDataURL('image/png');
}

// RGBA → RGB floats, as loom writes its own rendering.
export function rgbOf(rgba) {
  const rgb = new Float32Array((rgba.length / 4) * 3);
  for (let i = 0; i < rgba.length / 4; ++i) rgb.set(rgba.subarray(4 * i, 4 * i + 3), 3 * i);
  return Array.from(rgb);
}

// Σ|other − loom| / Σ|loom| over every texel and colour, and both renderings' means.
export function compare(rgba, loom, renderer) {
  let difference = 0, sum = 0, other = 0;
  for (let i = 0; i < loom.length / 3; ++i) {
    for (let c = 0; c < 3; ++c) {
      difference += Math.abs(rgba[4 * i + c] - loom[3 * i + c]);
      sum += Math.abs(loom[3 * i + c]);
      other += rgba[4 * i + c];
    }
  }
  const values = loom.length;
  return { relative_difference: difference / sum, mean_loom: sum / values, [`mean_${renderer}`]: other / values };
}
