#!/usr/bin/env bash
# README command (2): installs what is needed, builds everything and runs every test, then
# fuzzes the readers and runs the suites again under ASan + UBSan as far as CI's 30 minutes allow.
# .ci/run calls exactly this.
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
# Every test first: a run from an empty compiler cache spends about 19 of its 30 minutes on the
# main build, and its tests take about 8 more.
(cd build && ctest --output-on-failure --no-label-summary -j "$(nproc)")
echo "every test passed after $(( $(date +%s) - start )) s"

# Then the stages that check again, each one only if its build ends early enough for its own run
# to end by the budget's end (CI allows 30 min on 2 cores; 1.5 min kept for variation). With a
# warm compiler cache all of them run; with an empty one (a fresh machine) they do not, and the
# run says which were left out and the command that runs each.
budget_seconds=$(( 28 * 60 + 30 ))
budget_end=$(( start + budget_seconds ))
left_out=()
run_if_it_fits() {  # RUN_SECONDS NAME SCRIPT ARGS...: SCRIPT gets the seconds its build may take
  local run_seconds=$1 name=$2 build_seconds code=0
  shift 2
  build_seconds=$(( budget_end - $(date +%s) - run_seconds ))
  if (( build_seconds >= 60 )); then  # a shorter build is not worth starting
    bash "$@" "$build_seconds" || code=$?
  else
    code=3
  fi
  if (( code == 3 )); then
    left_out+=("$name (bash $*)")
    echo "$name left out: its build would not end in time for its run to end within $budget_seconds s"
  elif (( code != 0 )); then
    exit "$code"
  else
    echo "$name finished after $(( $(date +%s) - start )) s"
  fi
}
# The readers of hostile input (rig and plan YAML, the capture store's journal, stack and map
# files) fuzzed under ASan + UBSan, 20 s each (five targets, as many at once as there are cores):
# a crash, leak or hang fails the run.
run_if_it_fits 70 "fuzzing" scripts/fuzz.sh 20
# The suites of core, scan and the BRDF model under ASan + UBSan (any report fails the run).
run_if_it_fits 45 "the sanitized core, scan and model suites" scripts/sanitizers.sh ci
# Every other test that does not load LibTorch (the simulator, the devices and their peers, the
# sequencer, calibration, reconstruction) under ASan + UBSan too: its tests take about 11 min.
run_if_it_fits 660 "every sanitized suite" scripts/sanitizers.sh address
if (( ${#left_out[@]} > 0 )); then
  echo "every test passed; left out to stay within 30 minutes (a cold compiler cache):"
  printf '  %s\n' "${left_out[@]}"
else
  echo "every test passed, fuzzing and the sanitized suites included, after $(( $(date +%s) - start )) s"
fi
