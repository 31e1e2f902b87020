// Renders a MaterialX document (`loom export --mtlx`, or the one `loom eval` writes into
// REPORT/mtlx) with the shader MaterialX's own generator writes for it — the library's ESSL
// generator, run here on its WebAssembly build — drawn by WebGL2 in headless Chromium under each
// of REPORT/renderer/views.json's lights and views, and compares it texel by texel with loom's
// own rendering of the same maps (fitting/report/renderer_views.h). Writes
// REPORT/renderer/materialx-VIEW.png and .f32 (as loom's), materialx-comparison.json, and the
// page of every renderer beside loom (renderers-page.mjs).
//
// The scene is in millimetres, as loom's rendering is. MaterialX's point light falls off as
// 1 / (d + 1)², not 1 / d² (its mx_point_light): each view's intensity is scaled so that the two
// agree at the sample's centre; with d in millimetres they then differ by less than 0.01 % across
// a sample of a few centimetres a few hundred millimetres from the light.
//
// Usage: node render-mtlx.mjs REPORT [MTLX_DIR] [--max-mean-difference D]
// Exits 1 when the views' mean relative difference exceeds D, or on any page error.
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { errorMessage, loadMaterialX } from './materialx.mjs';
import { exitAgainstBound, readViews, renderInPage, saveRenderings } from './render-views.mjs';

const web = path.dirname(fileURLToPath(import.meta.url));
const pointLightId = 1;

function parseArguments(argv) {
  const options = { paths: [], maxMeanDifference: Infinity };
  for (let i = 0; i < argv.length; ++i) {
    if (argv[i] === '--max-mean-difference') options.maxMeanDifference = Number(argv[++i]);
    else options.paths.push(path.resolve(argv[i]));
  }
  if (options.paths.length === 1) options.paths.push(path.join(options.paths[0], 'mtlx'));
  if (options.paths.length !== 2 || Number.isNaN(options.maxMeanDifference)) {
    throw new Error('usage: node render-mtlx.mjs REPORT [MTLX_DIR] [--max-mean-difference D]');
  }
  return { report: options.paths[0], mtlx: options.paths[1], maxMeanDifference: options.maxMeanDifference };
}

// The generator's options for a direct-lit comparison: one point light, colour spaces converted
// in the shader into linear Rec. 709 (loom's), no output encoding, and the host's bitangents (those
// the mesh's texture coordinates give), as DCC hosts pass them. The environment light is turned
// off by its intensity uniform (hostValues): MaterialX 1.39.4's shader without an environment
// (SPECULAR_ENVIRONMENT_NONE) reads a uniform it does not declare (u_refractionTwoSided) and
// does not compile.
function configure(mx, context, stdlib) {
  const options = context.getOptions();
  options.targetColorSpaceOverride = 'lin_rec709';
  options.fileTextureVerticalFlip = false;
  options.hwSpecularEnvironmentMethod = mx.HwSpecularEnvironmentMethod.SPECULAR_ENVIRONMENT_FIS;
  options.hwSrgbEncodeOutput = false;
  options.hwImplicitBitangents = false;
  options.hwMaxActiveLightSources = 1;
  mx.HwShaderGenerator.bindLightShader(stdlib.getNodeDef('ND_point_light'), pointLightId, context);
}

// What the host sets where the document does not: no light from an environment.
const hostValues = { u_envLightIntensity: 0 };

function uniformValue(type, value) {
  if (value === undefined || value === null) return null;
  if (['float', 'integer', 'boolean', 'filename'].includes(type)) return value;
  if (typeof value.data === 'function') return [...value.data()];
  return null;  // strings, matrices (the host's) and closures: nothing the document sets
}

function uniformsOf(stage) {
  const uniforms = [];
  for (const [block, ports] of Object.entries(stage.getUniformBlocks())) {
    if (block === 'LightData') continue;  // the light's struct, set per view
    for (let i = 0; i < ports.size(); ++i) {
      const port = ports.get(i);
      const type = port.getType().getName();
      const name = port.getVariable();
      uniforms.push({ name, type, value: hostValues[name] ?? uniformValue(type, port.getValue()?.getData()) });
    }
  }
  return uniforms;
}

// The vertex shader as generated, but for where it puts the quad: each texel on its own pixel of
// the target, the maps' first row (the image's top, v = 1) on the target's first row.
function placedByTextureCoordinates(vertex) {
  const end = vertex.lastIndexOf('}');
  if (!vertex.includes('in vec2 i_texcoord_0;') || end < 0) throw new Error('the generated vertex shader reads no i_texcoord_0');
  return `${vertex.slice(0, end)}    gl_Position = vec4(2.0 * i_texcoord_0.x - 1.0, 1.0 - 2.0 * i_texcoord_0.y, 0.0, 1.0);\n}\n`;
}

async function generate(documentFile) {
  const mx = await loadMaterialX();
  const generator = mx.EsslShaderGenerator.create();
  const context = new mx.GenContext(generator);
  const stdlib = mx.loadStandardLibraries(context);
  configure(mx, context, stdlib);
  const doc = mx.createDocument();
  await mx.readFromXmlString(doc, await readFile(documentFile, 'utf8'), '');
  doc.setDataLibrary(stdlib);
  const materials = doc.getMaterialNodes();
  if (materials.length !== 1) throw new Error(`${documentFile}: ${materials.length} material nodes, expected 1`);
  let shader;
  try {
    shader = generator.generate(materials[0].getNamePath(), materials[0], context);
  } catch (error) {
    throw new Error(`${documentFile}: shader generation failed: ${errorMessage(mx, error)}`);
  }
  return {
    materialx: mx.getVersionString(),
    vertex: placedByTextureCoordinates(shader.getSourceCode('vertex')),
    pixel: shader.getSourceCode('pixel'),
    uniforms: [...uniformsOf(shader.getStage('vertex')), ...uniformsOf(shader.getStage('pixel'))],
  };
}

// loom's radiance ∝ I / d²; under MaterialX's falloff the same radiance at the sample's centre
// needs I · (d + 1)² / d².
function pointLight(view) {
  const d = Math.hypot(...view.light_mm);
  return { type: pointLightId, intensity: view.intensity * ((d + 1) / d) ** 2 };
}

async function main() {
  const options = parseArguments(process.argv.slice(2));
  const views = await readViews(options.report);
  const generated = await generate(path.join(options.mtlx, 'material.mtlx'));
  const roots = { '/web/': web, '/report/': options.report, '/mtlx/': options.mtlx };
  const spec = { ...generated, views, lights: views.views.map(pointLight), report: '/report', textures: '/mtlx' };
  const { check, errors } = await renderInPage(roots, '/web/render-check.html?page=render-mtlx-page.js', spec);
  check.materialx = generated.materialx;
  check.document = path.relative(options.report, path.join(options.mtlx, 'material.mtlx'));
  await saveRenderings(options.report, 'materialx', 'materialx-comparison.json', views, check);
  exitAgainstBound(check, errors, options.maxMeanDifference, `MaterialX ${check.materialx}'s ESSL shader, ${check.renderer}`);
}

// A missing or broken file is one line naming it, not a stack trace.
main().catch((error) => {
  console.error(`render-mtlx: ${error?.message ?? error}`);
  process.exit(1);
});
