// Validates glTF files with Khronos' glTF Validator (npm gltf-validator) and exits 1 unless
// every file has 0 errors, 0 warnings and 0 infos. Usage: node validate-gltf.mjs FILE.gltf...
// Prints one JSON line per file: its path, the validator's version and the issue counts and
// messages, so that a failing test names the file and the issue.
import { readFile } from 'node:fs/promises';
import path from 'node:path';
import validator from 'gltf-validator';

async function validate(file) {
  const asset = await readFile(file);
  const report = await validator.validateBytes(new Uint8Array(asset), {
    uri: path.basename(file),
    maxIssues: 100,
    externalResourceFunction: (uri) => readFile(path.resolve(path.dirname(file), decodeURIComponent(uri))),
  });
  const issues = report.issues;
  const messages = issues.messages.map((m) => `${m.code} at ${m.pointer ?? ''}: ${m.message}`);
  console.log(JSON.stringify({
    file,
    validator: report.validatorVersion,
    errors: issues.numErrors,
    warnings: issues.numWarnings,
    infos: issues.numInfos,
    hints: issues.numHints,
    messages,
  }));
  return issues.numErrors + issues.numWarnings + issues.numInfos === 0;
}

const files = process.argv.slice(2);
if (files.length === 0) {
  console.error('usage: node validate-gltf.mjs FILE.gltf...');
  process.exit(2);
}
let clean = true;
for (const file of files) {
  try {
    clean = (await validate(file)) && clean;
  } catch (error) {
    console.error(`${file}: ${error}`);
    clean = false;
  }
}
process.exit(clean ? 0 : 1);
