#!/usr/bin/env bash
# The eval report's interactive viewer (web/viewer.mjs) opened from disk in headless Chromium,
# inside its own network namespace: it loads with no console error, a screenshot shows the
# material and moving the light changes it (tests/viewer-test.mjs).
# Usage: viewer_test.sh LOOM RIG WORK_DIR
set -euo pipefail
work=$3
web=$(cd "$(dirname "$0")/.." && pwd)
bash "$web/tests/make-report.sh" "$1" "$2" "$work" 1 1
cd "$work"
node "$web/viewer.mjs" report
unshare -n node "$web/tests/viewer-test.mjs" report
