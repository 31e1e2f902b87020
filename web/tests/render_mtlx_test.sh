#!/usr/bin/env bash
# A fabric's MaterialX document, rendered by the shader MaterialX's own generator writes for it
# (web/render-mtlx.mjs: the library's ESSL generator, drawn by WebGL2 in headless Chromium inside
# its own network namespace), against loom's own rendering of the same maps under six of the
# stack's point-lit views: the page loads without errors and the mean relative difference stays
# within the bound (0.16 measured on this fabric; docs/benchmarks.md). The maps are the
# simulator's truth, so that what differs is the export and the renderer, not a fit. Two wrong
# documents must fail the same bound, so the check can fail: base and specular colours swapped,
# and the anisotropy turned the other way about the normal (specular_rotation read as 1 − r).
# Usage: render_mtlx_test.sh LOOM RIG WORK_DIR
set -euo pipefail
work=$3
web=$(cd "$(dirname "$0")/.." && pwd)
bash "$web/tests/make-report.sh" "$1" "$2" "$work" 2 6
cd "$work"
check() { unshare -n node "$web/render-mtlx.mjs" report "$1" --max-mean-difference 0.25; }
check report/mtlx
for file in materialx-comparison.json index.html materialx-obs0205.png; do
  test -s "report/renderer/$file" || { echo "no report/renderer/$file" >&2; exit 1; }
done
grep -q "MaterialX 1.39" report/renderer/index.html

cp -r report/mtlx swapped
cp report/mtlx/specular_color.png swapped/base_color.png && cp report/mtlx/base_color.png swapped/specular_color.png
cp -r report/mtlx turned
sed -i -e 's|<input name="specular_rotation" type="float" nodename="rotation" />|<input name="specular_rotation" type="float" nodename="turned" />|' \
  -e 's|  <normalmap name="shading_normal"|  <subtract name="turned" type="float">\n    <input name="in1" type="float" value="1" />\n    <input name="in2" type="float" nodename="rotation" />\n  </subtract>\n&|' \
  turned/material.mtlx
grep -q 'nodename="turned"' turned/material.mtlx
for wrong in swapped turned; do
  if check "$wrong" >"$wrong.log" 2>&1; then
    echo "the $wrong material passed the check" >&2
    exit 1
  fi
  grep "mean relative difference" "$wrong.log" | head -1
done
echo "the swapped and the turned material failed the bound, as they must"
