// REPORT/renderer/index.html: loom's own rendering of a report's views beside every other
// renderer's that has run — three.js rendering the glTF (render-check.mjs: comparison.json), the
// shader MaterialX generates for the MaterialX document (render-mtlx.mjs:
// materialx-comparison.json) and Blender's Cycles rendering a material built from the MaterialX
// textures and the glTF as Blender imports it (blender/render_check.py: cycles-comparison.json,
// cycles-gltf-comparison.json) — with each one's relative difference
// Σ|other − loom| / Σ|loom| and where its model departs from GD10-Ward.
//
// Usage: node renderers-page.mjs REPORT (render-check.mjs calls writeRenderersPage itself).
import { readFile, writeFile } from 'node:fs/promises';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const renderers = [
  {
    name: 'three.js', comparison: 'comparison.json', image: (view) => `threejs-${view}.png`,
    version: (c) => `three.js r${c.three} (${c.renderer})`,
    departs: 'renders <a href="../material/material.gltf">the glTF</a>: GGX for the Ward lobe (α = √2 σ), glTF\'s ' +
      'Schlick Fresnel rising to 1 at grazing angles where loom\'s rises to a_s, the diffuse darkened by (1 − F) where ' +
      'loom adds the two lobes, anisotropy dropped where normals tilt wider than the lobes (loom\'s ' +
      'fitting/report/gltf_export.h), 8-bit textures.',
  },
  {
    name: 'MaterialX', comparison: 'materialx-comparison.json', image: (view) => `materialx-${view}.png`,
    version: (c) => `MaterialX ${c.materialx}'s own ESSL shader for <a href="../${c.document}">the document</a> (${c.renderer})`,
    departs: 'Standard Surface: a dielectric GGX lobe (α = √2 σ per axis) of colour a_s · F0 / F0_max over a Lambertian ' +
      'base that it darkens where it reflects (loom adds the two lobes), its Fresnel rising to 1 at grazing angles where ' +
      'loom\'s rises to a_s, GGX\'s multiple-scattering compensation, 8-bit textures (loom\'s ' +
      'fitting/report/mtlx_export.h).',
  },
  {
    name: 'Cycles', comparison: 'cycles-comparison.json', image: (view) => `cycles-${view}.png`,
    version: (c) => `Blender ${c.blender} Cycles, ${c.samples} samples`,
    departs: 'renders a material built from <a href="../mtlx/material.mtlx">the MaterialX export</a>\'s textures: a ' +
      'Lambertian term added to an anisotropic GGX lobe (α = √2 σ per axis) of colour a_s · F0, without Fresnel\'s rise ' +
      'at grazing angles (loom\'s fitting/report/mtlx_export.h), 8-bit textures.',
  },
  {
    name: 'Cycles (glTF)', comparison: 'cycles-gltf-comparison.json', image: (view) => `cycles-gltf-${view}.png`,
    version: (c) => `Blender ${c.blender} Cycles, ${c.samples} samples, <a href="../material/material.gltf">the glTF</a> as ` +
      'Blender\'s importer builds it',
    departs: 'a Principled BSDF: GGX for the Ward lobe (α = √2 σ), KHR_materials_specular turned into Principled\'s ' +
      'Specular and Specular Tint, no anisotropy (Blender 3.4 reads no KHR_materials_anisotropy), the diffuse under the ' +
      'specular layer where loom adds the two, Fresnel rising to 1 at grazing angles, 8-bit textures.',
  },
];

async function readJson(file) {
  try {
    return JSON.parse(await readFile(file, 'utf8'));
  } catch (error) {
    if (error.code === 'ENOENT') return null;
    throw new Error(`${file}: ${error.message}`);
  }
}

export async function writeRenderersPage(report) {
  const dir = path.join(report, 'renderer');
  const views = await readJson(path.join(dir, 'views.json'));
  if (!views) throw new Error(`${dir}/views.json: not found (loom eval --renderer-views N writes it)`);
  const ran = [];
  for (const renderer of renderers) {
    const check = await readJson(path.join(dir, renderer.comparison));
    if (check) ran.push({ ...renderer, check });
  }
  const head = ran.map((r) => `<th>${r.name}</th><th>relative difference</th>`).join('');
  const rows = views.views.map((view, i) => {
    const cells = ran.map((r) => `<td><img src="${r.image(view.name)}"></td>` +
      `<td>${r.check.results[i].relative_difference.toFixed(3)}</td>`).join('');
    return `<tr><td>${view.name}<br><small>${view.description}</small></td><td><img src="${view.loom_png}"></td>${cells}</tr>`;
  }).join('\n');
  const means = ran.map((r) => `<li>${r.version(r.check)}: mean relative difference ` +
    `<b>${r.check.mean_relative_difference.toFixed(3)}</b>; ${r.departs}</li>`).join('\n');
  const missing = renderers.filter((r) => !ran.some((x) => x.name === r.name)).map((r) => r.name);
  await writeFile(path.join(dir, 'index.html'), `<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>loom: the material in other renderers</title>
<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}td,th{padding:4px 10px;border-bottom:1px solid #ccc;text-align:left;vertical-align:top}img{width:192px;image-rendering:pixelated}</style></head><body>
<h1>The material in other renderers beside loom's own rendering</h1>
<p>Each renderer draws the exported material under an isotropic point light and an orthographic camera from each
view; loom renders the fitted maps themselves (GD10-Ward) under the same light and view. Same exposure in each row.
Relative difference: Σ|renderer − loom| / Σ|loom| over every pixel and colour.</p>
<ul>
${means}
</ul>
${missing.length ? `<p>Not run yet: ${missing.join(', ')} (web/render-check.mjs; web/render-mtlx.mjs; blender/render_check.py).</p>` : ''}
<table><tr><th>view</th><th>loom</th>${head}</tr>
${rows}
</table>
</body></html>
`);
  return ran.map((r) => r.name);
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  if (process.argv.length !== 3) {
    console.error('usage: node renderers-page.mjs REPORT');
    process.exit(2);
  }
  writeRenderersPage(path.resolve(process.argv[2]))
    .then((names) => console.log(`wrote ${process.argv[2]}/renderer/index.html: loom beside ${names.join(', ') || 'no other renderer yet'}`))
    .catch((error) => { console.error(`renderers-page: ${error.message}`); process.exit(1); });
}
