// Adds the interactive viewer to a loom eval report written with --renderer-views (which puts
// the fit's glTF in REPORT/material): REPORT/viewer/index.html, the material in three.js under
// a light that follows the pointer, with the fitted parameter maps beside it. Everything it
// needs lies beside it and it opens from disk with no network: viewer.js is three.js and
// viewer/main.js bundled into one classic script (esbuild), material.js the glTF with its
// textures and buffer as data URIs (browsers refuse modules and textures from file:// URLs).
//
// Usage: node viewer.mjs REPORT
import { mkdir, readFile, writeFile, access } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { build } from 'esbuild';

const web = path.dirname(fileURLToPath(import.meta.url));
const mapNames = ['diffuse', 'specular', 'normal', 'sigma', 'alpha', 'height'];

async function bundle() {
  const result = await build({
    entryPoints: [path.join(web, 'viewer', 'main.js')], absWorkingDir: web, bundle: true, format: 'iife',
    minify: true, write: false, logLevel: 'error',
  });
  return result.outputFiles[0].contents;
}

// The glTF with every file it refers to inlined as a data URI.
async function embeddedGltf(dir) {
  const gltf = JSON.parse(await readFile(path.join(dir, 'material.gltf'), 'utf8'));
  const inline = async (uri, type) => `data:${type};base64,${(await readFile(path.join(dir, uri))).toString('base64')}`;
  for (const image of gltf.images ?? []) image.uri = await inline(image.uri, 'image/png');
  for (const buffer of gltf.buffers ?? []) buffer.uri = await inline(buffer.uri, 'application/octet-stream');
  return gltf;
}

async function exists(file) {
  try { await access(file); return true; } catch { return false; }
}

function escape(text) {
  return text.replace(/&/g, '&amp;').replace(/</g, '&lt;').replace(/>/g, '&gt;');
}

async function page(report, gltf) {
  const index = await readFile(path.join(report, 'index.html'), 'utf8').catch(() => '');
  const title = (index.match(/<title>loom: (.*?)<\/title>/) ?? [])[1] ?? path.basename(report);
  const maps = [];
  for (const name of mapNames) {
    if (await exists(path.join(report, `fit-${name}.png`))) {
      maps.push(`<figure><img src="../fit-${name}.png" alt="${name}"><figcaption>${name}</figcaption></figure>`);
    }
  }
  const choice = gltf.materials?.[0]?.extras?.loom_anisotropy ?? '';
  return `<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>loom: ${title} in three.js</title>
<style>body{font-family:sans-serif;margin:2em;background:#fff}#row{display:flex;gap:2em;align-items:flex-start}
canvas{width:640px;height:640px;cursor:crosshair}#maps{display:grid;grid-template-columns:repeat(2,160px);gap:0.5em}
figure{margin:0}img{width:160px;image-rendering:pixelated}figcaption{font-size:small}</style></head><body>
<h1>${title} in three.js</h1>
<p>Move the pointer over the material: the light follows it. Drag to turn the material, scroll to zoom.
The material is the fit's glTF (<a href="../material/material.gltf">material.gltf</a>: GD10-Ward approximated by
glTF's GGX, ${escape(choice)}); <a href="../renderer/index.html">renderer/index.html</a> compares three.js with loom.</p>
<p id="status"></p>
<div id="row"><canvas id="view" width="640" height="640"></canvas><div id="maps">${maps.join('\n')}</div></div>
<script src="material.js"></script>
<script src="viewer.js"></script>
</body></html>
`;
}

const report = process.argv[2];
if (!report || process.argv.length > 3) {
  console.error('usage: node viewer.mjs REPORT');
  process.exit(2);
}
const materialDir = path.join(report, 'material');
if (!(await exists(path.join(materialDir, 'material.gltf')))) {
  console.error(`${materialDir}/material.gltf: not found (write the report with loom eval --renderer-views N, N > 0)`);
  process.exit(1);
}
const out = path.join(report, 'viewer');
await mkdir(out, { recursive: true });
const gltf = await embeddedGltf(materialDir);
await writeFile(path.join(out, 'viewer.js'), await bundle());
await writeFile(path.join(out, 'material.js'), `window.loomMaterial = ${JSON.stringify({ gltf })};\n`);
await writeFile(path.join(out, 'index.html'), await page(report, gltf));
console.log(`viewer: ${path.join(out, 'index.html')}`);
