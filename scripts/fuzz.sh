#!/usr/bin/env bash
# Builds loom's libFuzzer targets with clang (ASan + UBSan) in build-fuzz/ and runs each for
# SECONDS (default 60), seeded from the corpus/ folder beside its source; crashes, leaks, undefined
# behaviour and slow inputs fail the run and land in build-fuzz/findings/. README command (2), and
# so CI, runs it for 20 s per target after the tests when its build fits CI's 30 minutes (issue
# #24), as many targets at once as the machine has cores; its random seed is fixed, so a run on
# one binary explores the same inputs first.
#   scripts/fuzz.sh [SECONDS [BUILD_SECONDS]]
# BUILD_SECONDS bounds the build as scripts/sanitizers.sh's does: if it has not finished by then no
# target runs and the script exits 3 (what is built so far stays for the next run).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bounded-build.sh
seconds=${1:-60}
build_seconds=${2:-0}
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DLOOM_BUILD_FUZZERS=ON -DLOOM_BUILD_TESTS=OFF -DLOOM_BUILD_BENCH=OFF \
  -DCMAKE_CXX_FLAGS="-O1 -g -fsanitize=fuzzer-no-link,address,undefined" > /dev/null
declare -A corpus=([rig_model_fuzzer]=core/fuzz/corpus [plan_fuzzer]=scan/fuzz/corpus
  [journal_fuzzer]=scan/fuzz/journal-corpus [stack_fuzzer]=core/fuzz/stack-corpus [maps_fuzzer]=fitting/fuzz/maps-corpus)
build=(cmake --build build-fuzz -j "$(nproc)" --target "${!corpus[@]}")
bounded_build "$build_seconds" "the fuzzers' build" "${build[@]}"
mkdir -p build-fuzz/findings
# One target per core at a time (each is single-threaded), every target's report printed whole.
fuzz_one() {  # FUZZER LOG
  local work="build-fuzz/corpus-$1" binary
  mkdir -p "$work"
  binary=$(find build-fuzz -name "$1" -type f -executable | head -1)
  # malloc may return NULL, as glibc's does for an impossible size: HDF5 asks for exabytes when a
  # header is damaged and reports the failure (loom's own `new` still throws, and is found).
  ASAN_OPTIONS=allocator_may_return_null=1 LSAN_OPTIONS=suppressions=fitting/fuzz/lsan.supp \
    "$binary" "$work" "${corpus[$1]}" -max_total_time="$seconds" -seed=1 -timeout=10 -rss_limit_mb=2048 \
    -artifact_prefix=build-fuzz/findings/"$1"- -print_final_stats=1 > "$2" 2>&1
}
fuzzers=("${!corpus[@]}")
failed=0
for ((first = 0; first < ${#fuzzers[@]}; first += $(nproc))); do
  batch=("${fuzzers[@]:first:$(nproc)}")
  pids=()
  for fuzzer in "${batch[@]}"; do
    fuzz_one "$fuzzer" "build-fuzz/$fuzzer.log" &
    pids+=($!)
  done
  for i in "${!batch[@]}"; do
    wait "${pids[$i]}" || failed=1
    echo "== ${batch[$i]}, $seconds s"
    tail -12 "build-fuzz/${batch[$i]}.log"
  done
done
exit "$failed"
