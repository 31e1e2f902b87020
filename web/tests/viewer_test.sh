#!/usr/bin/env bash
# The eval report's interactive viewer (web/viewer.mjs) opened from disk in headless Chromium,
# inside its own network namespace: it loads with no console error, a screenshot shows the
# material and moving the light changes it (tests/viewer-test.mjs).
# Usage: viewer_test.sh LOOM RIG WORK_DIR
set -euo pipefail
loom=$1 rig=$2 work=$3
web=$(cd "$(dirname "$0")/.." && pwd)
rm -rf "$work" && mkdir -p "$work"
cd "$work"
"$loom" sim render --rig "$rig" --object fabric:1 --stack --size 16 --truth truth.exr --out stack.exr >/dev/null
"$loom" eval truth.exr --stack stack.exr --out report --renderer-views 1 >/dev/null
node "$web/viewer.mjs" report
unshare -n node "$web/tests/viewer-test.mjs" report
