// Renders a loom eval report's glTF (REPORT/material, written with --renderer-views) in three.js
// in headless Chromium under each of REPORT/renderer/views.json's lights and views, and compares
// it pixel by pixel with loom's own rendering of the same fitted maps (fitting/report/renderer_views.h).
// Writes REPORT/renderer/threejs-VIEW.png and .f32 (as loom's), comparison.json and index.html (renderers-page.mjs:
// every renderer that has run beside loom, with its relative difference Σ|three.js − loom| / Σ|loom|).
//
// Usage: node render-check.mjs REPORT [--max-mean-difference D]
// Exits 1 when the views' mean relative difference exceeds D, or on any page error.
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { exitAgainstBound, readViews, renderInPage, saveRenderings } from './render-views.mjs';

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

async function main() {
  const options = parseArguments(process.argv.slice(2));
  const views = await readViews(options.report);
  const { check, errors } = await renderInPage(
    { '/three/': path.join(web, 'node_modules', 'three'), '/web/': web, '/report/': options.report },
    '/web/render-check.html', '/report');
  await saveRenderings(options.report, 'threejs', 'comparison.json', views, check);
  exitAgainstBound(check, errors, options.maxMeanDifference, `three.js r${check.three}, ${check.renderer}`);
}

// A missing or broken file is one line naming it, not a stack trace.
main().catch((error) => {
  console.error(`render-check: ${error?.message ?? error}`);
  process.exit(1);
});
