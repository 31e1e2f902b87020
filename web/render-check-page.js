// The browser side of render-check.mjs: renders a report's glTF (REPORT/material) in three.js
// under each of REPORT/renderer/views.json's lights and views, and compares every pixel with
// loom's own rendering of the same view.
//
// Pixel for texel: the quad is drawn so that each render-target pixel is one texel of the maps
// (the vertex shader places the quad by its texture coordinates), while the shading still sees
// the real geometry and an orthographic camera along the view direction, so that the view
// direction is the same at every pixel, as in loom's rendering.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { compare, pngOf, rgbOf } from './view-comparison.js';

function theMesh(root) {
  let mesh = null;
  root.traverse((object) => { if (object.isMesh && !mesh) mesh = object; });
  if (!mesh) throw new Error('material.gltf has no mesh');
  return mesh;
}

// The quad's texture coordinates span [0, uMax] × [0, vMax] (the maps' part of padded textures).
function uvSpan(mesh) {
  const uv = mesh.geometry.attributes.uv;
  let u = 0, v = 0;
  for (let i = 0; i < uv.count; ++i) { u = Math.max(u, uv.getX(i)); v = Math.max(v, uv.getY(i)); }
  return new THREE.Vector2(u, v);
}

function placeByTextureCoordinates(material, span) {
  material.onBeforeCompile = (shader) => {
    const end = '#include <fog_vertex>';
    if (!shader.vertexShader.includes(end)) throw new Error(`three.js ${THREE.REVISION}: no ${end} in the vertex shader`);
    shader.uniforms.loomUvSpan = { value: span };
    // Row 0 of the maps (v = 0) at the bottom of the target: readRenderTargetPixels' first row.
    shader.vertexShader = 'uniform vec2 loomUvSpan;\n' +
      shader.vertexShader.replace(end, `${end}\n\tgl_Position = vec4( 2.0 * uv / loomUvSpan - 1.0, 0.0, 1.0 );`);
  };
  material.needsUpdate = true;
}

export async function renderViews(report) {
  const views = await (await fetch(`${report}/renderer/views.json`)).json();
  const gltf = await new GLTFLoader().loadAsync(`${report}/material/material.gltf`);
  const mesh = theMesh(gltf.scene);
  placeByTextureCoordinates(mesh.material, uvSpan(mesh));
  const { width, height } = views;

  const renderer = new THREE.WebGLRenderer({ antialias: false });
  renderer.toneMapping = THREE.NoToneMapping;
  const target = new THREE.WebGLRenderTarget(width, height, {
    type: THREE.FloatType, minFilter: THREE.NearestFilter, magFilter: THREE.NearestFilter,
  });
  const scene = new THREE.Scene();
  scene.add(gltf.scene);
  const light = new THREE.PointLight(0xffffff, 1, 0, 2);  // no cut-off, inverse-square falloff
  scene.add(light);
  const camera = new THREE.OrthographicCamera(-1, 1, 1, -1, 0.01, 10);
  camera.up.set(0, 0, -1);  // the sample's +y: never parallel to a view from above

  const results = [];
  for (const view of views.views) {
    light.position.fromArray(view.gltf.light_m);
    light.intensity = view.threejs_intensity;
    camera.position.fromArray(view.gltf.view);
    camera.lookAt(0, 0, 0);
    renderer.setRenderTarget(target);
    renderer.render(scene, camera);
    const rgba = new Float32Array(width * height * 4);
    renderer.readRenderTargetPixels(target, 0, 0, width, height, rgba);
    const loom = new Float32Array(await (await fetch(`${report}/renderer/${view.loom}`)).arrayBuffer());
    if (loom.length !== width * height * 3) throw new Error(`${view.loom}: ${loom.length} floats, not ${width * height * 3}`);
    results.push({
      name: view.name, ...compare(rgba, loom, 'threejs'), png: pngOf(rgba, width, height, view.white), rgb: rgbOf(rgba),
    });
  }
  renderer.setRenderTarget(null);
  return { three: THREE.REVISION, renderer: rendererName(renderer), results };
}

function rendererName(renderer) {
  const gl = renderer.getContext();
  return `${gl.getParameter(gl.VERSION)}, ${gl.getParameter(gl.RENDERER)}`;
}
