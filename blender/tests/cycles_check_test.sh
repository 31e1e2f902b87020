#!/usr/bin/env bash
# A fabric's maps rendered by headless Blender's Cycles under six of the stack's point-lit views,
# against loom's own rendering of the same maps (render_check.py), twice: a material built from
# the MaterialX textures (loom eval's own MaterialX export and the one `loom export --mtlx`
# writes; 0.19 measured on this fabric) and the report's glTF as Blender's importer builds it
# (0.28; docs/benchmarks.md), each within its bound. The maps are the simulator's truth, so that
# what differs is the export and the renderer, not a fit. A material with its base and specular
# colours swapped must fail the same bound, in each path, so the check can fail.
# Usage: cycles_check_test.sh LOOM RIG WORK_DIR
set -euo pipefail
loom=$1 work=$3
here=$(cd "$(dirname "$0")/.." && pwd)
bash "$here/../web/tests/make-report.sh" "$loom" "$2" "$work" 2 6
cd "$work"
"$loom" export truth.exr --mtlx mtlx >/dev/null
render() {
  unshare -n blender -b --factory-startup --python-exit-code 1 --python "$here/render_check.py" -- "$@" 2>&1 |
    grep -E "relative difference|Error"
}
check() { render report "$1" --max-mean-difference 0.25; }
check_gltf() { render "$1" --gltf --max-mean-difference 0.35; }
check mtlx
check report/mtlx
check_gltf report
test -s report/renderer/cycles-comparison.json && test -s report/renderer/cycles-gltf-comparison.json
node "$here/../web/renderers-page.mjs" report
grep -q "Blender 3" report/renderer/index.html && grep -q "cycles-obs" report/renderer/index.html
grep -q "cycles-gltf-obs" report/renderer/index.html

cp -r mtlx swapped
cp mtlx/specular_color.png swapped/base_color.png && cp mtlx/base_color.png swapped/specular_color.png
if check swapped; then
  echo "a material with its colours swapped passed the check" >&2
  exit 1
fi
cp -r report swapped-report
cp report/material/specular_color.png swapped-report/material/base_color.png
cp report/material/base_color.png swapped-report/material/specular_color.png
if check_gltf swapped-report; then
  echo "a glTF with its colours swapped passed the check" >&2
  exit 1
fi
echo "the swapped materials failed the bounds, as they must"
