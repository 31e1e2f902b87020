// Renders a loom eval report's glTF (REPORT/material, written with --renderer-views) in three.js
// in headless Chromium under each of REPORT/renderer/views.json's lights and views, and compares
// it pixel by pixel with loom's own rendering of the same fitted maps (fitting/report/renderer_views.h).
// Writes REPORT/renderer/threejs-VIEW.png and .f32 (as loom's), comparison.json and index.html (renderers-page.mjs:
// every renderer that has run beside loom, with its relative difference Σ|three.js − loom| / Σ|loom|).
//
// Usage: node render-check.mjs REPORT [--max-mean-difference D]
// Exits 1 when the views' mean relative difference exceeds D, or on any page error.
import { readFile, writeFile } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { openBrowser, origin } from './browser.mjs';
import { writeRenderersPage } from './renderers-page.mjs';

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
await writeRenderersPage(options.report);
for (const r of check.results) console.log(`${r.name}: relative difference ${r.relative_difference.toFixed(4)}`);
console.log(`mean relative difference ${check.mean_relative_difference.toFixed(4)} (three.js r${check.three}, ${check.renderer})`);
const mean = check.mean_relative_difference;
if (errors.length > 0) console.error(`page errors:\n${errors.join('\n')}`);
if (!(mean <= options.maxMeanDifference)) {
  console.error(`mean relative difference ${mean.toFixed(4)} > --max-mean-difference ${options.maxMeanDifference}`);
}
process.exit(errors.length === 0 && mean <= options.maxMeanDifference ? 0 : 1);
