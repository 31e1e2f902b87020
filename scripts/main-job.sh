#!/usr/bin/env bash
# README command (1): installs what is needed, builds loom and runs the main job on the
# simulated tac7-mini rig (`loom demo`, apps/demo_command.cc):
#   1. calibration scan (dark, the wedge target at 8 turntable angles, white tile, colour chart)
#      and `loom calibrate geometry` → build/demo/calib;
#   2. scan of a procedural fabric (fabric:1) with the low-gloss plan → build/demo/scan;
#   3. `loom reconstruct --calib`: structured-light heightmap, every HDR image projected onto it
#      in the top view → build/demo/reconstruction/stack.exr (the whole 128 × 128 px sample);
#   4. `loom fit` with the CNN shipped for tac7-mini and with the CNN refined by the batched
#      refiner (the main result), each evaluated against the simulator's ground truth →
#      build/demo/report-*/;
#   5. a one-screen summary (parameter errors, re-render L1, time per stage) and
#      build/demo/summary.json. LOOM_DEMO_BASELINE=1 adds Ceres alone and CNN + Ceres (about 8 more minutes);
#   6. the main result in other renderers beside loom's own rendering of the same views
#      → build/demo/report-cnn+refine/renderer/index.html: its glTF in three.js (web/render-check.mjs)
#      and its MaterialX document in the shader MaterialX generates for it (web/render-mtlx.mjs), in
#      headless Chromium; Blender's Cycles rendering a material built from the MaterialX textures
#      and the glTF as Blender imports it (blender/render_check.py); and the report's interactive
#      viewer (web/viewer.mjs) → build/demo/report-cnn+refine/viewer/index.html.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh loom
methods=cnn,cnn+refine
if [[ "${LOOM_DEMO_BASELINE:-0}" == 1 ]]; then methods=ceres,cnn+ceres,cnn,cnn+refine; fi
./build/apps/loom version
rm -rf build/demo
./build/apps/loom demo --rig configs/rig/tac7-mini.yaml --object fabric:1 --preset low --methods "$methods" --out build/demo
# Each renderer in its own network namespace: Chromium reaches nothing (web/browser.mjs serves
# every file), nor does Blender.
cycles() {
  unshare -n blender -b --factory-startup --python-exit-code 1 --python blender/render_check.py -- \
    build/demo/report-cnn+refine "$@" 2>&1 | grep -E "mean relative difference|Error"
}
cycles         # a material built from the MaterialX textures
cycles --gltf  # the glTF as Blender's importer builds it
# Each writes renderer/index.html with every renderer that has run, Cycles' included.
unshare -n node web/render-check.mjs build/demo/report-cnn+refine
unshare -n node web/render-mtlx.mjs build/demo/report-cnn+refine
node web/viewer.mjs build/demo/report-cnn+refine
