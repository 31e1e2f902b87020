// Headless Chromium (Debian's, driven by playwright-core) serving files from disk under the
// made-up origin http://loom.invalid: nothing leaves the machine, every request is answered
// from `roots` (URL prefix → directory) or refused; file:// pages load as they are. Console
// errors and page errors are kept.
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import { chromium } from 'playwright-core';

export const origin = 'http://loom.invalid';

const contentTypes = {
  '.html': 'text/html', '.js': 'text/javascript', '.mjs': 'text/javascript', '.json': 'application/json',
  '.gltf': 'model/gltf+json', '.bin': 'application/octet-stream', '.f32': 'application/octet-stream',
  '.png': 'image/png',
};

// The flags a root Chromium needs here, and none of its own network traffic.
const chromiumArgs = [
  '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--disable-quic',
  '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync',
];

async function serve(route, roots) {
  const url = new URL(route.request().url());
  for (const [prefix, dir] of Object.entries(roots)) {
    if (url.origin !== origin || !url.pathname.startsWith(prefix)) continue;
    const file = path.join(dir, decodeURIComponent(url.pathname.slice(prefix.length)));
    if (!file.startsWith(path.resolve(dir))) break;
    try {
      const body = await readFile(file);
      return route.fulfill({ body, contentType: contentTypes[path.extname(file)] ?? 'application/octet-stream' });
    } catch {
      return route.fulfill({ status: 404, body: `not found: ${file}` });
    }
  }
  return url.protocol === 'file:' ? route.continue() : route.abort();
}

export async function openBrowser(roots = {}, viewport = { width: 800, height: 600 }) {
  const browser = await chromium.launch({ executablePath: process.env.LOOM_CHROMIUM ?? '/usr/bin/chromium', args: chromiumArgs });
  const page = await browser.newPage({ viewport });
  const errors = [];
  page.on('console', (message) => { if (message.type() === 'error') errors.push(message.text()); });
  page.on('pageerror', (error) => errors.push(error.message));
  await page.route('**/*', (route) => serve(route, roots));
  return { browser, page, errors };
}
