// The eval report's interactive viewer: the fitted material (its glTF, embedded by viewer.mjs
// in material.js as window.loomMaterial) in three.js under a point light that follows the
// pointer. Drag to turn the material, wheel to zoom. Bundled by viewer.mjs into one classic
// script, so that the report opens from disk (browsers refuse ES modules from file://).
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const canvas = document.getElementById('view');
const status = document.getElementById('status');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.toneMapping = THREE.NeutralToneMapping;
const scene = new THREE.Scene();
scene.background = new THREE.Color(0x202020);
scene.add(new THREE.AmbientLight(0xffffff, 0.05));
const light = new THREE.PointLight(0xffffff, 1, 0, 2);
scene.add(light);
const camera = new THREE.PerspectiveCamera(35, canvas.width / canvas.height, 1e-4, 100);
const controls = new OrbitControls(camera, canvas);

let lightDistance = 1;

function render() { renderer.render(scene, camera); }

// Pointer at (x, y) ∈ [−1, 1]² of the canvas → the light over that point of the hemisphere, as
// seen from the camera's side: right is the view's right, up is away from the viewer.
function lightAt(x, y) {
  const right = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0).setY(0).normalize();
  const away = new THREE.Vector3(0, 1, 0).cross(right).normalize();
  const r = Math.min(Math.hypot(x, y), 0.98);
  const scale = r > 0 ? r / Math.hypot(x, y) : 0;
  const direction = right.multiplyScalar(x * scale).add(away.multiplyScalar(y * scale));
  direction.y = Math.sqrt(1 - r * r);
  light.position.copy(direction.multiplyScalar(lightDistance));
  render();
}

function onPointer(event) {
  if (event.buttons !== 0) return;  // dragging turns the material
  const box = canvas.getBoundingClientRect();
  lightAt(2 * (event.clientX - box.left) / box.width - 1, 1 - 2 * (event.clientY - box.top) / box.height);
}

function linearFromSrgb(c) {
  return c <= 0.04045 ? c / 12.92 : Math.pow((c + 0.055) / 1.055, 2.4);
}

// The mean linear albedo of the base colour texture (its sRGB texels averaged after decoding).
function meanAlbedo(texture) {
  const image = texture?.image;
  if (!image) return 0.5;
  const canvas2d = document.createElement('canvas');
  canvas2d.width = image.width;
  canvas2d.height = image.height;
  const context = canvas2d.getContext('2d');
  context.drawImage(image, 0, 0);
  const { data } = context.getImageData(0, 0, image.width, image.height);
  let sum = 0;
  for (let i = 0; i < data.length; i += 4) {
    for (let c = 0; c < 3; ++c) sum += linearFromSrgb(data[i + c] / 255);
  }
  return sum / (0.75 * data.length);
}

function show(gltf) {
  scene.add(gltf.scene);
  // Scaled to a metre: three.js clamps a point light's falloff within 10 cm of it (1 / max(d², 0.01)),
  // and a sample is centimetres wide.
  const size = new THREE.Box3().setFromObject(gltf.scene).getSize(new THREE.Vector3());
  gltf.scene.scale.setScalar(1 / Math.max(size.x, size.z));
  const extent = 1;
  lightDistance = 3 * extent;
  // Exposure: the material's mean diffuse radiance 0.4 under the light from above (a white
  // Lambertian surface would be 1 at an irradiance of π), whatever its albedo.
  let material = null;
  gltf.scene.traverse((object) => { if (object.isMesh && !material) material = object.material; });
  const irradiance = Math.PI * Math.min(0.4 / Math.max(meanAlbedo(material?.map), 0.01), 10);
  light.intensity = irradiance * lightDistance * lightDistance;
  camera.near = extent / 100;
  camera.far = extent * 100;
  camera.position.set(0, 1.5 * extent, 1.2 * extent);
  camera.updateProjectionMatrix();
  controls.target.set(0, 0, 0);
  controls.update();
  controls.addEventListener('change', render);
  canvas.addEventListener('pointermove', onPointer);
  lightAt(0.3, 0.4);
  window.loomViewer = { ready: true, lightAt };
}

new GLTFLoader().parse(JSON.stringify(window.loomMaterial.gltf), '', show, (error) => {
  status.textContent = `could not load the material: ${error.message ?? error}`;
  console.error(error);
});
