// What every render check (render-check.mjs, render-mtlx.mjs) does around its page: reads a
// report's renderer views, renders them in a page of headless Chromium, writes each view's
// rendering beside loom's (RENDERER-VIEW.png and .f32) with the comparison, refreshes the page of
// every renderer, and exits 1 when the mean relative difference exceeds the bound or the page
// reported an error.
import { readFile, writeFile } from 'node:fs/promises';
import path from 'node:path';
import { openBrowser, origin } from './browser.mjs';
import { writeRenderersPage } from './renderers-page.mjs';

export async function readViews(report) {
  const file = path.join(report, 'renderer', 'views.json');
  const views = JSON.parse(await readFile(file, 'utf8'));
  if (views.views.length === 0) throw new Error(`${file}: no views to render`);
  return views;
}

// Opens `page` (a path under the made-up origin; `roots` serve it) and returns what its
// window.renderViews(argument) returns, with the page's errors.
export async function renderInPage(roots, page, argument) {
  const { browser, page: tab, errors } = await openBrowser(roots);
  try {
    await tab.goto(`${origin}${page}`);
    await tab.waitForFunction(() => window.renderCheckReady === true, null, { timeout: 60000 });
    const check = await tab.evaluate((value) => window.renderViews(value), argument);
    return { check, errors };
  } finally {
    await browser.close();
  }
}

// `check.results[i]`: view i's comparison with its PNG (a data URL) and RGB floats, which are
// written as PREFIX-VIEW.png and .f32 and left out of COMPARISON (a JSON file in REPORT/renderer).
export async function saveRenderings(report, prefix, comparison, views, check) {
  const dir = path.join(report, 'renderer');
  for (const [i, result] of check.results.entries()) {
    const name = views.views[i].name;
    await writeFile(path.join(dir, `${prefix}-${name}.png`), Buffer.from(result.png.split(',')[1], 'base64'));
    await writeFile(path.join(dir, `${prefix}-${name}.f32`), Buffer.from(new Float32Array(result.rgb).buffer));
    delete result.png;
    delete result.rgb;
  }
  check.mean_relative_difference = check.results.reduce((s, r) => s + r.relative_difference, 0) / check.results.length;
  await writeFile(path.join(dir, comparison), JSON.stringify(check, null, 2) + '\n');
  await writeRenderersPage(report);
  for (const r of check.results) console.log(`${r.name}: relative difference ${r.relative_difference.toFixed(4)}`);
}

export function exitAgainstBound(check, errors, maxMeanDifference, renderer) {
  const mean = check.mean_relative_difference;
  console.log(`mean relative difference ${mean.toFixed(4)} (${renderer})`);
  if (errors.length > 0) console.error(`page errors:\n${errors.join('\n')}`);
  if (!(mean <= maxMeanDifference)) {
    console.error(`mean relative difference ${mean.toFixed(4)} > --max-mean-difference ${maxMeanDifference}`);
  }
  process.exit(errors.length === 0 && mean <= maxMeanDifference ? 0 : 1);
}
