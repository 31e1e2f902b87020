#!/usr/bin/env bash
# README command (1): installs what is needed, builds loom and runs the main job on the
# simulated tac7-mini rig:
#   1. scan a procedural fabric (fabric:1) with the rig's low-gloss plan → build/demo/scan;
#   2. reconstruct it: structured-light heightmap, every HDR image projected onto it in the top
#      view → build/demo/reconstruction/stack.exr (calibration: the rig YAML's nominal model —
#      geometric and radiometric calibration from a calibration scan are not built yet, issue #6);
#   3. fit the whole 128 × 128 px sample with the CNN shipped for tac7-mini and with the CNN
#      refined by Ceres (the main result) and evaluate each against the simulator's ground truth
#      → build/demo/report-<method>/index.html. LOOM_DEMO_BASELINE=1 adds Ceres alone (the
#      baseline; ~10 more minutes on 2 cores).
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
stage "reconstruct"
"$loom" reconstruct "$demo/scan" --out "$demo/reconstruction"
stack="$demo/reconstruction/stack.exr"
stage "ground truth (the simulator's maps on the stack's grid)"
"$loom" sim render --rig "$rig" --stack --preset low --truth "$demo/truth.exr" --out "$demo/fast-path-stack.exr"
methods="cnn cnn+ceres"
if [[ "${LOOM_DEMO_BASELINE:-0}" == 1 ]]; then methods="$methods ceres"; fi
for method in $methods; do
  stage "fit: $method"
  "$loom" fit "$stack" --method "$method" --out "$demo/fit-$method"
  stage "evaluate $method against the ground truth"
  "$loom" eval "$demo/fit-$method/svbrdf.exr" --stack "$stack" --reference "$demo/truth.exr" \
    --out "$demo/report-$method" --title "fabric:1 on tac7-mini (scan → reconstruct → $method)"
done
stage "done"
echo "reports: $demo/report-cnn+ceres/index.html (main result), $demo/report-cnn/index.html"
