#!/usr/bin/env bash
# README command (1): installs what is needed, builds loom and runs the main job on the
# simulated tac7-mini rig. Today that is two halves that do not meet yet:
#   1. scan a procedural fabric (fabric:1) with the rig's low-gloss plan → build/demo/scan;
#   2. the simulator's fast-path stack of the same fabric and plan (what calibration +
#      reconstruction of that scan will produce, once they exist: issue #6) → Ceres fit →
#      evaluation against the ground truth → build/demo/report/index.html.
# The stack covers the whole 128 × 128 px sample. It is fitted three ways and each is evaluated:
# the CNN shipped for tac7-mini (configs/models/tac7-mini), the CNN refined by Ceres (the main
# result), and Ceres alone from appearance clusters (the baseline the CNN is measured against).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh loom
loom=./build/apps/loom
demo=build/demo
rig=configs/rig/tac7-mini.yaml
start=$(date +%s)
stage() { echo; echo "== $1 ($(( $(date +%s) - start )) s)"; }
"$loom" version
rm -rf "$demo" && mkdir -p "$demo"
stage "plan"
"$loom" plan --rig "$rig" --preset low
stage "scan"
"$loom" scan --rig "$rig" --preset low --object fabric:1 --out "$demo/scan"
stage "fast-path stack (stands in for calibrate + reconstruct)"
"$loom" sim render --rig "$rig" --stack --preset low --truth "$demo/truth.exr" --out "$demo/stack.exr"
for method in cnn cnn+ceres ceres; do
  stage "fit: $method"
  "$loom" fit "$demo/stack.exr" --method "$method" --out "$demo/fit-$method"
  stage "evaluate $method against the ground truth"
  "$loom" eval "$demo/fit-$method/svbrdf.exr" --stack "$demo/stack.exr" --reference "$demo/truth.exr" \
    --out "$demo/report-$method" --title "fabric:1 on tac7-mini (fast-path stack, $method)"
done
stage "done"
echo "reports: $demo/report-cnn+ceres/index.html (main result), $demo/report-cnn/index.html, $demo/report-ceres/index.html"
