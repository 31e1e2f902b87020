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
# projector under ASan + UBSan (any report fails the run).
bash scripts/sanitizers.sh ci
elapsed=$(( $(date +%s) - start ))
echo "sanitized suites finished after $elapsed s"
# Every other test that does not load LibTorch (peers, calibration, reconstruction) under ASan +
# UBSan too, when the run so far shows a warm compiler cache: this far takes about 5 min from a
# warm cache and 25 from an empty one, and the rest of the lane about 8 min more from a warm cache
# and 15 from an empty one, which would take a cold run past CI's 30 minutes.
if (( elapsed <= 600 )); then
  bash scripts/sanitizers.sh address
  echo "every sanitized suite finished after $(( $(date +%s) - start )) s"
else
  echo "the rest of the sanitized suites not run: $elapsed s had passed (a cold compiler cache);" \
    "scripts/sanitizers.sh address runs them"
fi
cd build
ctest --output-on-failure --no-label-summary -j "$(nproc)"
