// The MaterialX library's WebAssembly build (@needle-tools/materialx, pinned in package-lock.json)
// loaded in Node: its core, the standard libraries and the shader generators.
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const bin = path.join(path.dirname(fileURLToPath(import.meta.url)), 'node_modules/@needle-tools/materialx/bin');

// The Emscripten module is written for CommonJS and the browser: in an ES module it needs
// `require` and its own path, and its library bundle is published as .data.txt.
export async function loadMaterialX() {
  globalThis.require = createRequire(import.meta.url);
  globalThis.__filename = path.join(bin, 'JsMaterialXGenShader.js');
  globalThis.__dirname = bin;
  const { default: MaterialX } = await import(path.join(bin, 'JsMaterialXGenShader.js'));
  return MaterialX({ locateFile: (file) => path.join(bin, file.endsWith('.data') ? `${file}.txt` : file) });
}

// The library's own message for an exception it threw as a pointer.
export function errorMessage(mx, error) {
  return typeof error === 'number' ? mx.getExceptionMessage(error) : String(error?.message ?? error);
}
