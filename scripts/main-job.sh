#!/usr/bin/env bash
# README command (1): installs what is needed, builds loom and runs the main job on the
# simulated rig. Until the end-to-end issue lands, the main job is: show the plan of the
# tac7-mini rig and scan a procedural fabric with it (calibration, reconstruction, fitting and
# the report come with their issues, under this same command).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh loom
loom=./build/apps/loom
"$loom" version
"$loom" plan --rig configs/rig/tac7-mini.yaml --preset low
rm -rf build/demo-scan
"$loom" scan --rig configs/rig/tac7-mini.yaml --preset low --object fabric:1 --out build/demo-scan
