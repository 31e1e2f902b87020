#!/usr/bin/env bash
# The glTF of a fabric, in three.js in headless Chromium (no network: inside its own network
# namespace), against loom's own rendering of the same maps under six of the stack's point-lit
# views: the page loads without errors and the mean relative difference stays within the bound
# (0.2 to 0.25 measured on fabrics 1 to 3; docs/benchmarks.md). The maps are the simulator's
# truth, so that what differs is the export and the renderer, not a fit.
# Usage: render_check_test.sh LOOM RIG WORK_DIR
set -euo pipefail
work=$3
web=$(cd "$(dirname "$0")/.." && pwd)
bash "$web/tests/make-report.sh" "$1" "$2" "$work" 2 6
cd "$work"
unshare -n node "$web/render-check.mjs" report --max-mean-difference 0.35
for file in comparison.json index.html; do test -s "report/renderer/$file" || { echo "no report/renderer/$file" >&2; exit 1; }; done
