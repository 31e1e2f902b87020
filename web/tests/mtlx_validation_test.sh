#!/usr/bin/env bash
# Every MaterialX document that `loom export --mtlx` writes is valid to the MaterialX library
# itself (web/validate-mtlx.mjs: its validate(), every node and input against the standard
# libraries' definitions, every texture present, and an ESSL shader generated for the material):
# procedural fabrics in and out of GD10's model, a uniform tile, and maps from a fit with skipped
# (masked) pixels. A document with an input Standard Surface does not have is refused, so the
# check can fail.
# Usage: mtlx_validation_test.sh LOOM WORK_DIR
set -euo pipefail
loom=$1 work=$2
web=$(cd "$(dirname "$0")/.." && pwd)
rm -rf "$work" && mkdir -p "$work"
cd "$work"

"$loom" sim material --kind fabric --seed 3 --size 24 --out fabric >/dev/null
"$loom" sim material --kind fabric-out-of-model --seed 5 --size 16 --pixel-mm 0.25 --out out-of-model >/dev/null
"$loom" sim material --kind white-tile --size 8 --out tile >/dev/null
"$loom" sim capture --size 16 --lights 16 --out capture >/dev/null
"$loom" import capture --out masked.exr >/dev/null
"$loom" fit masked.exr --method lambert --out fit --log-level warning >/dev/null

for maps in fabric out-of-model tile fit; do
  "$loom" export "$maps/svbrdf.exr" --mtlx "mtlx-$maps" >/dev/null
  node "$web/validate-mtlx.mjs" "mtlx-$maps/material.mtlx" >"mtlx-$maps.json"
  test "$(ls "mtlx-$maps"/*.png | wc -l)" -eq 6
done

cp -r mtlx-fabric mtlx-unknown-input
sed -i 's/name="specular_IOR"/name="specular_ior"/' mtlx-unknown-input/material.mtlx
if node "$web/validate-mtlx.mjs" mtlx-unknown-input/material.mtlx >unknown-input.json; then
  echo "an input standard_surface does not have passed the check" >&2
  exit 1
fi
grep -q "no node definition" unknown-input.json
echo "4 documents valid; an unknown input refused"
