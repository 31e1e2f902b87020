// Renders a loom eval report's glTF (REPORT/material, written with --renderer-views) in three.js
// in headless Chromium under each of REPORT/renderer/views.json's lights and views, and compares
// it pixel by pixel with loom's own rendering of the same fitted maps (fitting/report/renderer_views.h).
// Writes REPORT/renderer/threejs-VIEW.png and .f32 (as loom's), comparison.json and index.html (both renderings side
// by side, with their relative difference Σ|three.js − loom| / Σ|loom|).
//
// Usage: node render-check.mjs REPORT [--max-mean-difference D]
// Exits 1 when the views' mean relative difference exceeds D, or on any page error.
import { readFile, writeFile } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { openBrowser, origin } from './browser.mjs';

const web = path.dirname(fileURLToPath(import.meta.url));

function parseArguments(argv) {
  const options = { report: null, maxMeanDifference: Infinity };
  for (let i = 0; i < argv.length; ++i) {
    if (argv[i] === '--max-mean-difference') options.maxMeanDifference = Number(argv[++i]);
    else if (!options.report) options.report = path.resolve(argv[i]);
    else throw new Error(`unexpected argument ${argv[i]}`);
  }
  if (!options.report || Number.isNaN(options.maxMeanDifference)) {
    throw new Error('usage: node render-check.mjs REPORT [--max-mean-difference D]');
  }
  return options;
}

function page(views, check) {
  const rows = views.views.map((view, i) => {
    const r = check.results[i];
    return `<tr><td>${view.name}<br><small>${view.description}</small></td><td><img src="${view.loom_png}"></td>` +
      `<td><img src="threejs-${view.name}.png"></td><td>${r.relative_difference.toFixed(3)}</td>` +
      `<td>${r.mean_loom.toExponential(3)}</td><td>${r.mean_threejs.toExponential(3)}</td></tr>`;
  }).join('\n');
  return `<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>loom: the glTF in three.js</title>
<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}td,th{padding:4px 10px;border-bottom:1px solid #ccc;text-align:left;vertical-align:top}img{width:192px;image-rendering:pixelated}</style></head><body>
<h1>The glTF in three.js beside loom's own rendering</h1>
<p>three.js r${check.three} (${check.renderer}) renders <a href="../material/material.gltf">material.gltf</a> under an
isotropic point light and an orthographic camera from each view; loom renders the fitted maps themselves (GD10-Ward)
under the same light and view. Same exposure in each pair. The difference is the glTF export's approximation
(GGX for Ward, glTF's Fresnel and its diffuse darkening, 8-bit textures; see loom's fitting/report/gltf_export.h) and
three.js' shading. Relative difference: Σ|three.js − loom| / Σ|loom| over every pixel and colour.</p>
<table><tr><th>view</th><th>loom</th><th>three.js</th><th>relative difference</th><th>mean loom</th><th>mean three.js</th></tr>
${rows}
</table>
<p>Mean relative difference over the views: ${check.mean_relative_difference.toFixed(3)}</p>
</body></html>
`;
}

const options = parseArguments(process.argv.slice(2));
const rendererDir = path.join(options.report, 'renderer');
const views = JSON.parse(await readFile(path.join(rendererDir, 'views.json'), 'utf8'));
if (views.views.length === 0) {
  console.error(`${rendererDir}/views.json: no views to render`);
  process.exit(1);
}
const { browser, page: tab, errors } = await openBrowser({
  '/three/': path.join(web, 'node_modules', 'three'), '/web/': web, '/report/': options.report,
});
let check;
try {
  await tab.goto(`${origin}/web/render-check.html`);
  await tab.waitForFunction(() => window.renderCheckReady === true, null, { timeout: 60000 });
  check = await tab.evaluate(() => window.renderViews('/report'));
} finally {
  await browser.close();
}
for (const [i, result] of check.results.entries()) {
  const name = views.views[i].name;
  await writeFile(path.join(rendererDir, `threejs-${name}.png`), Buffer.from(result.png.split(',')[1], 'base64'));
  await writeFile(path.join(rendererDir, `threejs-${name}.f32`), Buffer.from(new Float32Array(result.rgb).buffer));
  delete result.png;
  delete result.rgb;
}
check.mean_relative_difference = check.results.reduce((s, r) => s + r.relative_difference, 0) / check.results.length;
await writeFile(path.join(rendererDir, 'comparison.json'), JSON.stringify(check, null, 2) + '\n');
await writeFile(path.join(rendererDir, 'index.html'), page(views, check));
for (const r of check.results) console.log(`${r.name}: relative difference ${r.relative_difference.toFixed(4)}`);
console.log(`mean relative difference ${check.mean_relative_difference.toFixed(4)} (three.js r${check.three}, ${check.renderer})`);
const mean = check.mean_relative_difference;
if (errors.length > 0) console.error(`page errors:\n${errors.join('\n')}`);
if (!(mean <= options.maxMeanDifference)) {
  console.error(`mean relative difference ${mean.toFixed(4)} > --max-mean-difference ${options.maxMeanDifference}`);
}
process.exit(errors.length === 0 && mean <= options.maxMeanDifference ? 0 : 1);
