#!/usr/bin/env bash
# README command (2): installs what is needed, builds everything and runs every test.
# The last lines are ctest's summary. .ci/run calls exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
bash scripts/install-deps.sh
bash scripts/build.sh
echo "build finished after $(( $(date +%s) - start )) s"
# The readers of hostile input (rig and plan YAML, the capture store's journal, stack and map
# files) fuzzed under ASan + UBSan, 20 s each: a crash, leak or hang fails the run.
bash scripts/fuzz.sh 20
echo "fuzzing finished after $(( $(date +%s) - start )) s"
# The suites of core, scan, the BRDF model, the simulator, the sim devices, the sequencer and the
# projector under ASan + UBSan (any report fails the run); the rest of the sanitized suites is
# `scripts/sanitizers.sh address`, over CI's time on a cold cache.
bash scripts/sanitizers.sh ci
echo "sanitized suites finished after $(( $(date +%s) - start )) s"
cd build
ctest --output-on-failure --no-label-summary -j "$(nproc)"
