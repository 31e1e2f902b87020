#!/usr/bin/env bash
# Builds the test suites that do not load LibTorch with a sanitizer and runs their tests through
# ctest, with the peers and wrappers the normal suite uses (issue #24):
#   scripts/sanitizers.sh address   # ASan + UBSan (any report fails the run), in build-asan/
#   scripts/sanitizers.sh ci        # the same over the suites CI can afford (below), in build-asan/
#   scripts/sanitizers.sh thread    # TSan over ParallelFor, the sequencer and camera streams, in build-thread/
# A second argument, SECONDS, bounds the build: if it has not finished by then no test runs and
# the script exits 3 (what is built so far stays for the next run).
# The address lane runs every test of the modules that never load LibTorch (those labelled
# without_torch in CMakeLists.txt; fitting's CNN tests load it, apps' run the loom binary, which
# loads it for the CNN's commands); the `ci` lane the suites of core (configs, images, EXR,
# geometry, ParallelFor), scan (the capture store, its journal and plans) and the BRDF model.
# README command (2), and so CI, runs both after the normal suite, each when its build ends early
# enough for its tests to end within CI's 30 minutes, i.e. from a warm compiler cache (each lane
# prints its build and test times).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/bounded-build.sh
kind=${1:-address}
build_seconds=${2:-0}
# The ASan + UBSan lanes build with clang at -O1 (what ASan's own documentation advises): their
# objects take about half the time g++ -O2 takes under the same sanitizers. The TSan lane stays
# g++ -O2, as its GLib suppressions were found with it.
compiler=(-DCMAKE_CXX_COMPILER=clang++) opt=-O1
case "$kind" in
  address) flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined"
           suites=(without_torch_tests)  # every test executable of those modules (CMakeLists.txt)
           peers=(loom-modbus-sim) ;;
  ci)      flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined"
           suites=(core_test scan_test fitting_model_test) peers=() ;;
  thread)  flags="-fsanitize=thread" compiler=() opt=-O2
           suites=(core_test hal_modbus_test hal_aravis_test acquisition_sim_test) peers=(loom-modbus-sim) ;;
  *) echo "usage: $0 address|ci|thread" >&2; exit 2 ;;
esac
dir="build-$kind"
[ "$kind" != thread ] && dir=build-asan  # the same flags for the ci lane as the full one: one build for both
start=$(date +%s)
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DLOOM_BUILD_BENCH=OFF "${compiler[@]}" \
  -DCMAKE_CXX_FLAGS="$opt -fno-omit-frame-pointer $flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" > /dev/null
build=(cmake --build "$dir" -j "$(nproc)" --target "${suites[@]}" "${peers[@]}")
bounded_build "$build_seconds" "the $kind lane's build" "${build[@]}"
echo "$kind build finished after $(( $(date +%s) - start )) s"
# umockdev's preload library comes before ASan's runtime in the wrapped tests: let it.
export ASAN_OPTIONS=detect_leaks=1:verify_asan_link_order=0 UBSAN_OPTIONS=print_stacktrace=1 TSAN_OPTIONS=halt_on_error=1
export LSAN_OPTIONS="suppressions=$PWD/scripts/lsan-suppressions.txt"
export TSAN_OPTIONS="$TSAN_OPTIONS:suppressions=$PWD/scripts/tsan-suppressions.txt"
if [ "$kind" = address ]; then
  # Every test of the modules labelled without_torch (CMakeLists.txt).
  ctest --test-dir "$dir" -L '^without_torch$' --output-on-failure --no-label-summary -j "$(nproc)"
else  # the TSan suites and CI's: gtest binaries that need no peer, run directly
  failed=0
  for suite in "${suites[@]}"; do
    echo "== $suite"
    "$(find "$dir" -name "$suite" -type f -executable | head -1)" --gtest_brief=1 || failed=1
  done
  [ "$failed" = 0 ]
fi
echo "$kind lane finished after $(( $(date +%s) - start )) s"
