#!/usr/bin/env bash
# The glTF of a fabric, in three.js in headless Chromium (no network: inside its own network
# namespace), against loom's own rendering of the same maps under six of the stack's point-lit
# views: the page loads without errors and the mean relative difference stays within the bound
# (0.2 to 0.25 measured on fabrics 1 to 3; docs/benchmarks.md). The maps are the simulator's
# truth, so that what differs is the export and the renderer, not a fit.
# Usage: render_check_test.sh LOOM RIG WORK_DIR
set -euo pipefail
loom=$1 rig=$2 work=$3
web=$(cd "$(dirname "$0")/.." && pwd)
rm -rf "$work" && mkdir -p "$work"
cd "$work"
"$loom" sim render --rig "$rig" --object fabric:2 --stack --size 16 --truth truth.exr --out stack.exr >/dev/null
"$loom" eval truth.exr --stack stack.exr --out report --renderer-views 6 >/dev/null
unshare -n node "$web/render-check.mjs" report --max-mean-difference 0.35
for file in comparison.json index.html; do test -s "report/renderer/$file" || { echo "no report/renderer/$file" >&2; exit 1; }; done
