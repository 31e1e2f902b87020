#!/usr/bin/env bash
# The web tests' input: WORK_DIR/report, `loom eval`'s report of a simulated fabric's ground truth
# (a 16 × 16 px fast-path stack of tac7-mini) with VIEWS renderer views and the glTF.
# Usage: make-report.sh LOOM RIG WORK_DIR FABRIC_SEED VIEWS
set -euo pipefail
loom=$1 rig=$2 work=$3 seed=$4 views=$5
rm -rf "$work" && mkdir -p "$work"
cd "$work"
"$loom" sim render --rig "$rig" --object "fabric:$seed" --stack --size 16 --truth truth.exr --out stack.exr >/dev/null
"$loom" eval truth.exr --stack stack.exr --out report --renderer-views "$views" >/dev/null
