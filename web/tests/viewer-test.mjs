// Opens a report's viewer (REPORT/viewer/index.html, from web/viewer.mjs) from disk in headless
// Chromium and checks that it loads with no console or page error, that a screenshot of the
// canvas shows the material (not blank, not one colour), and that moving the light changes it.
// Keeps the screenshots as REPORT/viewer/screenshot-*.png. Usage: node viewer-test.mjs REPORT
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import { openBrowser } from '../browser.mjs';

// Statistics of the canvas' pixels: the share that differ from the background, the distinct
// colours (quantised to 5 bits a channel) and the luminance's standard deviation.
function canvasStatistics() {
  const canvas = document.getElementById('view');
  const copy = document.createElement('canvas');
  copy.width = canvas.width;
  copy.height = canvas.height;
  const context = copy.getContext('2d');
  context.drawImage(canvas, 0, 0);
  const { data } = context.getImageData(0, 0, copy.width, copy.height);
  const colours = new Set();
  let material = 0, sum = 0, squares = 0;
  const n = data.length / 4;
  for (let i = 0; i < data.length; i += 4) {
    const [r, g, b] = [data[i], data[i + 1], data[i + 2]];
    if (Math.abs(r - 0x20) + Math.abs(g - 0x20) + Math.abs(b - 0x20) > 6) ++material;
    colours.add(((r >> 3) << 10) | ((g >> 3) << 5) | (b >> 3));
    const y = 0.2126 * r + 0.7152 * g + 0.0722 * b;
    sum += y;
    squares += y * y;
  }
  const mean = sum / n;
  return { materialShare: material / n, colours: colours.size, luminanceStd: Math.sqrt(squares / n - mean * mean),
    pixels: Array.from(data.filter((_, i) => i % 4 !== 3)) };
}

function meanAbsoluteChange(a, b) {
  let sum = 0;
  for (let i = 0; i < a.length; ++i) sum += Math.abs(a[i] - b[i]);
  return sum / a.length;
}

// Until the viewer says it is ready, or fails: a page error ends the wait at once.
async function waitUntilReady(page, errors) {
  for (const start = Date.now(); Date.now() - start < 60000;) {
    if (errors.length > 0) throw new Error(`the viewer failed to load: ${errors.join('; ')}`);
    if (await page.evaluate(() => window.loomViewer?.ready === true)) return;
    await new Promise((resolve) => setTimeout(resolve, 100));
  }
  throw new Error('the viewer was not ready after 60 s');
}

const report = path.resolve(process.argv[2] ?? '');
const viewer = path.join(report, 'viewer');
const { browser, page, errors } = await openBrowser({}, { width: 1100, height: 900 });
const failures = [];
try {
  await page.goto(pathToFileURL(path.join(viewer, 'index.html')).href);
  await waitUntilReady(page, errors);
  const before = await page.evaluate(canvasStatistics);
  await page.locator('#view').screenshot({ path: path.join(viewer, 'screenshot-light-1.png') });
  await page.evaluate(() => window.loomViewer.lightAt(-0.7, -0.5));
  const after = await page.evaluate(canvasStatistics);
  await page.locator('#view').screenshot({ path: path.join(viewer, 'screenshot-light-2.png') });
  const change = meanAbsoluteChange(before.pixels, after.pixels);
  console.log(JSON.stringify({ material_share: before.materialShare, colours: before.colours,
    luminance_std: before.luminanceStd, change_when_the_light_moves: change }));
  if (before.materialShare < 0.2) failures.push(`only ${(100 * before.materialShare).toFixed(1)} % of the canvas shows the material`);
  if (before.colours < 100) failures.push(`${before.colours} distinct colours: a colour card, not a material`);
  if (before.luminanceStd < 5) failures.push(`luminance standard deviation ${before.luminanceStd.toFixed(2)}: blank`);
  if (change < 1) failures.push(`moving the light changed the pixels by ${change.toFixed(3)} on average`);
} finally {
  await browser.close();
}
failures.push(...errors.map((e) => `page error: ${e}`));
for (const failure of failures) console.error(failure);
process.exit(failures.length === 0 ? 0 : 1);
