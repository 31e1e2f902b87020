// Checks a MaterialX document with the MaterialX library itself (its WebAssembly build, pinned in
// package-lock.json): MaterialX's own validate(); every node bound to a node definition of the
// standard libraries, every input one its definition declares with the definition's type, every
// connection to a node of the input's type, every file present; then the library's ESSL shader
// generator generates the document's material. Prints a JSON summary; exit 1 on any problem.
//
//   node web/validate-mtlx.mjs DIR/material.mtlx
import fs from 'node:fs';
import path from 'node:path';
import { errorMessage, loadMaterialX } from './materialx.mjs';

function checkNode(node, doc, folder, problems) {
  const where = `node '${node.getName()}' (${node.getCategory()}, ${node.getType()})`;
  const nodedef = node.getNodeDef();
  if (!nodedef) {
    problems.push(`${where}: no node definition in the standard libraries`);
    return;
  }
  for (const input of node.getInputs()) {
    const declared = nodedef.getActiveInput(input.getName());
    if (!declared) {
      problems.push(`${where}: input '${input.getName()}' is not one of ${nodedef.getName()}'s`);
      continue;
    }
    if (declared.getType() !== input.getType()) {
      problems.push(`${where}: input '${input.getName()}' is ${input.getType()}, ${nodedef.getName()} declares ${declared.getType()}`);
    }
    const upstream = input.getNodeName();
    if (upstream) {
      const source = doc.getNode(upstream);
      if (!source) problems.push(`${where}: input '${input.getName()}' connects to '${upstream}', which is not in the document`);
      else if (source.getType() !== input.getType()) {
        problems.push(`${where}: input '${input.getName()}' (${input.getType()}) connects to '${upstream}' of type ${source.getType()}`);
      }
    }
    if (input.getType() === 'filename' && !fs.existsSync(path.join(folder, input.getValueString()))) {
      problems.push(`${where}: file '${input.getValueString()}' is not beside the document`);
    }
  }
}

async function main() {
  const file = process.argv[2];
  if (!file) {
    console.error('usage: node validate-mtlx.mjs DOCUMENT.mtlx');
    process.exit(2);
  }
  const mx = await loadMaterialX();
  const generator = mx.EsslShaderGenerator.create();
  const context = new mx.GenContext(generator);
  const stdlib = mx.loadStandardLibraries(context);
  const doc = mx.createDocument();
  await mx.readFromXmlString(doc, fs.readFileSync(file, 'utf8'), '');
  doc.setDataLibrary(stdlib);
  const problems = [];
  if (!doc.validate()) problems.push("MaterialX's validate() reports the document invalid");
  const nodes = doc.getNodes();
  for (const node of nodes) checkNode(node, doc, path.dirname(file), problems);
  const materials = doc.getMaterialNodes();
  if (materials.length !== 1) problems.push(`${materials.length} material nodes, expected 1`);
  let pixelShaderBytes = 0;
  if (materials.length === 1 && problems.length === 0) {
    try {
      const shader = generator.generate(materials[0].getNamePath(), materials[0], context);
      pixelShaderBytes = shader.getSourceCode('pixel').length;
    } catch (error) {
      problems.push(`shader generation failed: ${errorMessage(mx, error)}`);
    }
    if (pixelShaderBytes === 0 && problems.length === 0) problems.push('shader generation gave an empty pixel shader');
  }
  console.log(JSON.stringify({ materialx: mx.getVersionString(), nodes: nodes.length, pixel_shader_bytes: pixelShaderBytes, problems }, null, 2));
  process.exit(problems.length === 0 ? 0 : 1);
}

// An uncaught error would print the whole minified library with it.
main().catch((error) => {
  console.error(`validate-mtlx: ${error?.message ?? error}`);
  process.exit(1);
});
