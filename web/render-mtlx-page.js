// The browser side of render-mtlx.mjs: draws the ESSL shader that MaterialX's own generator wrote
// for a document with WebGL2, under each of a report's renderer views, and compares every texel
// with loom's own rendering of the same view.
//
// The host's part, as any MaterialX viewer's: the maps' quad in the sample frame (millimetres, z up;
// u along +x, v up the image, which is −y), its normal, tangent (+u) and bitangent (+v, as the
// normal map's green encodes it), the document's uniforms at their values, its textures, one
// point light and the camera's position. Pixel for texel: the generated vertex shader also places
// the quad by its texture coordinates, so that each target pixel is one texel, read at its centre.
import { compare, pngOf, rgbOf } from './view-comparison.js';

function compile(gl, type, source) {
  const shader = gl.createShader(type);
  gl.shaderSource(shader, source);
  gl.compileShader(shader);
  if (!gl.getShaderParameter(shader, gl.COMPILE_STATUS)) {
    throw new Error(`the generated ${type === gl.VERTEX_SHADER ? 'vertex' : 'pixel'} shader: ${gl.getShaderInfoLog(shader)}`);
  }
  return shader;
}

function link(gl, vertex, pixel) {
  const program = gl.createProgram();
  gl.attachShader(program, compile(gl, gl.VERTEX_SHADER, vertex));
  gl.attachShader(program, compile(gl, gl.FRAGMENT_SHADER, pixel));
  gl.linkProgram(program);
  if (!gl.getProgramParameter(program, gl.LINK_STATUS)) throw new Error(`linking: ${gl.getProgramInfoLog(program)}`);
  return program;
}

// Two triangles over the quad, each vertex's attributes by the generated shader's input names.
function quadAttributes(halfWidth, halfHeight) {
  const corners = [[-1, 1, 0, 0], [1, 1, 1, 0], [1, -1, 1, 1], [-1, -1, 0, 1]];  // (x, y) signs → (u, v)
  const order = [0, 1, 2, 0, 2, 3];
  return {
    i_position: order.flatMap((i) => [corners[i][0] * halfWidth, corners[i][1] * halfHeight, 0]),
    i_normal: order.flatMap(() => [0, 0, 1]),
    i_tangent: order.flatMap(() => [1, 0, 0]),
    i_bitangent: order.flatMap(() => [0, -1, 0]),
    i_texcoord_0: order.flatMap((i) => [corners[i][2], corners[i][3]]),
  };
}

function bindAttributes(gl, program, attributes) {
  for (const [name, values] of Object.entries(attributes)) {
    const location = gl.getAttribLocation(program, name);
    if (location < 0) continue;  // an input the shader does not read
    gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ARRAY_BUFFER, new Float32Array(values), gl.STATIC_DRAW);
    gl.enableVertexAttribArray(location);
    gl.vertexAttribPointer(location, values.length / 6, gl.FLOAT, false, 0, 0);
  }
}

// A texture as the file holds it: no colour conversion by the browser (the shader applies the
// document's colour spaces), rows flipped so that the image's top row is v = 1, a texel each.
async function loadTexture(gl, url) {
  const response = await fetch(url);
  if (!response.ok) throw new Error(`${url}: ${response.status}`);
  const image = await createImageBitmap(await response.blob(),
    { colorSpaceConversion: 'none', premultiplyAlpha: 'none', imageOrientation: 'flipY' });
  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, gl.RGBA, gl.UNSIGNED_BYTE, image);
  for (const parameter of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, parameter, gl.NEAREST);
  for (const parameter of [gl.TEXTURE_WRAP_S, gl.TEXTURE_WRAP_T]) gl.texParameteri(gl.TEXTURE_2D, parameter, gl.CLAMP_TO_EDGE);
  return texture;
}

const setters = {
  float: (gl, at, v) => gl.uniform1f(at, v),
  integer: (gl, at, v) => gl.uniform1i(at, v),
  boolean: (gl, at, v) => gl.uniform1i(at, v ? 1 : 0),
  vector2: (gl, at, v) => gl.uniform2fv(at, v),
  vector3: (gl, at, v) => gl.uniform3fv(at, v),
  color3: (gl, at, v) => gl.uniform3fv(at, v),
  vector4: (gl, at, v) => gl.uniform4fv(at, v),
  color4: (gl, at, v) => gl.uniform4fv(at, v),
  matrix44: (gl, at, v) => gl.uniformMatrix4fv(at, false, v),
};

// The document's uniforms at the values the generator gives them; each file a texture unit.
// A texture no file fills (the environment's): one black texel.
function blackTexture(gl) {
  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA8, 1, 1, 0, gl.RGBA, gl.UNSIGNED_BYTE, new Uint8Array([0, 0, 0, 255]));
  return texture;
}

async function setDocumentUniforms(gl, program, uniforms, textureRoot) {
  let unit = 0;
  for (const { name, type, value } of uniforms) {
    const at = gl.getUniformLocation(program, name);
    if (at === null) continue;
    if (type === 'filename') {
      gl.activeTexture(gl.TEXTURE0 + unit);
      gl.bindTexture(gl.TEXTURE_2D, value ? await loadTexture(gl, `${textureRoot}/${value}`) : blackTexture(gl));
      gl.uniform1i(at, unit++);
    } else if (value !== null && setters[type]) {
      setters[type](gl, at, value);
    }
  }
}

const identity = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];

function setView(gl, program, view, light) {
  const set = (name, type, value) => {
    const at = gl.getUniformLocation(program, name);
    if (at !== null) setters[type](gl, at, value);
  };
  for (const matrix of ['u_worldMatrix', 'u_worldInverseTransposeMatrix', 'u_viewProjectionMatrix', 'u_envMatrix']) {
    set(matrix, 'matrix44', identity);
  }
  // Far along the view direction: the same direction to the camera from every texel, as an
  // orthographic camera gives.
  set('u_viewPosition', 'vector3', view.view.map((c) => 1e5 * c));
  set('u_numActiveLightSources', 'integer', 1);
  set('u_lightData[0].type', 'integer', light.type);
  set('u_lightData[0].position', 'vector3', view.light_mm);
  set('u_lightData[0].color', 'color3', [1, 1, 1]);
  set('u_lightData[0].intensity', 'float', light.intensity);
  set('u_lightData[0].decay_rate', 'float', 2);
}

function floatTarget(gl, width, height) {
  if (!gl.getExtension('EXT_color_buffer_float')) throw new Error('WebGL2 without EXT_color_buffer_float');
  const texture = gl.createTexture();
  gl.bindTexture(gl.TEXTURE_2D, texture);
  gl.texImage2D(gl.TEXTURE_2D, 0, gl.RGBA32F, width, height, 0, gl.RGBA, gl.FLOAT, null);
  const framebuffer = gl.createFramebuffer();
  gl.bindFramebuffer(gl.FRAMEBUFFER, framebuffer);
  gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, texture, 0);
  return framebuffer;
}

// spec: the generated shaders, the document's uniforms, the views (views.json), each view's light
// (type id, intensity in MaterialX's units), where the report and the textures are served.
export async function renderViews(spec) {
  const { views } = spec;
  const { width, height } = views;
  const canvas = document.createElement('canvas');
  const gl = canvas.getContext('webgl2', { antialias: false });
  if (!gl) throw new Error('no WebGL2');
  const program = link(gl, spec.vertex, spec.pixel);
  gl.useProgram(program);
  bindAttributes(gl, program, quadAttributes((width * views.pixel_mm) / 2, (height * views.pixel_mm) / 2));
  // The target first: making it binds a texture, which would take the last material texture's unit.
  gl.bindFramebuffer(gl.FRAMEBUFFER, floatTarget(gl, width, height));
  await setDocumentUniforms(gl, program, spec.uniforms, spec.textures);
  gl.viewport(0, 0, width, height);
  const results = [];
  for (const [i, view] of views.views.entries()) {
    setView(gl, program, view, spec.lights[i]);
    gl.clearColor(0, 0, 0, 1);
    gl.clear(gl.COLOR_BUFFER_BIT);
    gl.drawArrays(gl.TRIANGLES, 0, 6);
    const rgba = new Float32Array(width * height * 4);
    gl.readPixels(0, 0, width, height, gl.RGBA, gl.FLOAT, rgba);
    const loom = new Float32Array(await (await fetch(`${spec.report}/renderer/${view.loom}`)).arrayBuffer());
    if (loom.length !== width * height * 3) throw new Error(`${view.loom}: ${loom.length} floats, not ${width * height * 3}`);
    results.push({ name: view.name, ...compare(rgba, loom, 'materialx'), png: pngOf(rgba, width, height, view.white), rgb: rgbOf(rgba) });
  }
  return { renderer: `${gl.getParameter(gl.VERSION)}, ${gl.getParameter(gl.RENDERER)}`, results };
}
