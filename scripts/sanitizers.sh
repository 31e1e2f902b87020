#!/usr/bin/env bash
# Builds the test suites that do not load LibTorch with a sanitizer and runs them (issue #24):
#   scripts/sanitizers.sh address   # ASan + UBSan (any report fails the run), in build-address/
#   scripts/sanitizers.sh thread    # TSan, in build-thread/
# Not part of CI: a second instrumented build would not fit CI's 30 minutes on a fresh machine.
# On this 2-core machine the address build and run take about 15 minutes (the sequencer's suite
# alone runs 3), the thread build about 4.
set -euo pipefail
cd "$(dirname "$0")/.."
kind=${1:-address}
case "$kind" in
  address) flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined"
           suites=(core_test scan_test sim_test hal_modbus_test acquisition_sim_test) ;;
  thread)  flags="-fsanitize=thread"
           suites=(core_test hal_modbus_test) ;;
  *) echo "usage: $0 address|thread" >&2; exit 2 ;;
esac
dir="build-$kind"
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DLOOM_BUILD_BENCH=OFF \
  -DCMAKE_CXX_FLAGS="-O1 -fno-omit-frame-pointer $flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" > /dev/null
cmake --build "$dir" -j "$(nproc)" --target "${suites[@]}" loom-modbus-sim
export ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 TSAN_OPTIONS=halt_on_error=1
failed=0
for suite in "${suites[@]}"; do
  binary=$(find "$dir" -name "$suite" -type f -executable | head -1)
  echo "== $suite"
  "$binary" --gtest_brief=1 || failed=1
done
exit "$failed"
