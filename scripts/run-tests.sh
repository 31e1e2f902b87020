#!/usr/bin/env bash
# README command (2): installs what is needed, builds everything and runs every test.
# The last lines are ctest's summary. .ci/run calls exactly this.
set -euo pipefail
cd "$(dirname "$0")/.."
start=$(date +%s)
# The build folders take about 2 GB (build/ 0.7, build-asan/ 1.0, build-fuzz/ 0.2; 6.5 GB
# before debug info became line tables only), the compiler cache up to 5 GB more, and the
# compiler writes its temporaries to TMPDIR: say so now rather than as a compiler's "No space
# left on device" minutes into the build (a CI run failed so).
need_free_gib() {  # FOLDER GIB
  local free_kib
  free_kib=$(df -Pk "$1" | awk 'NR == 2 {print $4}')
  if (( free_kib < $2 * 1024 * 1024 )); then
    echo "error: $(( free_kib / 1024 )) MiB free in $1 ($(df -P "$1" | awk 'NR == 2 {print $6}')), the build and" \
      "tests need $2 GiB: free some space there" >&2
    exit 1
  fi
}
need_free_gib . 7
need_free_gib "${TMPDIR:-/tmp}" 1
bash scripts/install-deps.sh
# The compiler cache's hits and misses so far ("0 0" without ccache): a cold cache is what makes a
# run slow, so the build's line says how warm it was.
ccache_counts() {
  ccache --print-stats 2> /dev/null |
    awk '$1 ~ /^(direct|preprocessed)_cache_hit$/ {hits += $2} $1 == "cache_miss" {misses = $2}
         END {print hits + 0, misses + 0}'
}
read -r hits_before misses_before < <(ccache_counts)
bash scripts/build.sh
read -r hits misses < <(ccache_counts)
echo "build finished after $(( $(date +%s) - start )) s (compiler cache: $(( hits - hits_before )) hits," \
  "$(( misses - misses_before )) misses)"
# The readers of hostile input (rig and plan YAML, the capture store's journal, stack and map
# files) fuzzed under ASan + UBSan, 20 s each: a crash, leak or hang fails the run.
bash scripts/fuzz.sh 20
echo "fuzzing finished after $(( $(date +%s) - start )) s"
# The suites of core, scan and the BRDF model under ASan + UBSan (any report fails the run).
bash scripts/sanitizers.sh ci
echo "sanitized suites finished after $(( $(date +%s) - start )) s"
# Every other test that does not load LibTorch (the simulator, the devices and their peers, the
# sequencer, calibration, reconstruction) under ASan + UBSan too, if its build finishes by the run's
# 16th minute: its tests take about 7 min and the normal suite's about 6.5, so the run stays within
# CI's 30 minutes. From a warm compiler cache it does (the build takes seconds); from an empty one
# it does not, and the run takes about 28 min on a fresh machine with 2 cores (sanitizers.sh).
build_deadline=$(( start + 16 * 60 - $(date +%s) ))
code=0
if (( build_deadline > 0 )); then
  bash scripts/sanitizers.sh address "$build_deadline" || code=$?
else
  code=3
fi
if (( code == 3 )); then
  echo "the rest of the sanitized suites not run: their build would not finish by minute 16" \
    "(a cold compiler cache); scripts/sanitizers.sh address runs them"
elif (( code != 0 )); then
  exit "$code"
else
  echo "every sanitized suite finished after $(( $(date +%s) - start )) s"
fi
cd build
ctest --output-on-failure --no-label-summary -j "$(nproc)"
