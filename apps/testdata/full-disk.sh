#!/bin/sh
# Outputs on a disk that fills: `loom export --axf/--gltf` and `loom model --out` fail with an
# error naming the path given, leave nothing at it (or what was there, as it was) and no hidden
# temporary beside it. Runs inside scan/run_in_small_tmpfs.sh (a 256 KiB tmpfs at
# $LOOM_SMALL_TMPFS). Usage: full-disk.sh LOOM MODEL_DIR
set -u
loom=$1 model=$2 disk=$LOOM_SMALL_TMPFS
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
failures=0
fail() { echo "FAILED: $*"; failures=$((failures + 1)); }
# expect_refused NAME COMMAND...: exit 1, the message names $disk/NAME, and only the filler and
# the earlier file are on the disk afterwards.
expect_refused() {
  name=$1
  shift
  "$@" > "$work/out" 2>&1
  code=$?
  [ "$code" = 1 ] || fail "$name: exit $code, expected 1: $(cat "$work/out")"
  grep -q "$disk/$name" "$work/out" || fail "$name: the error does not name $disk/$name: $(cat "$work/out")"
  left=$(ls -A "$disk" | grep -v -x -e fill -e m.axf | tr '\n' ' ')
  [ -z "$left" ] || fail "$name: left on the disk: $left"
}
"$loom" sim material --size 64 --out "$work/material" > /dev/null || fail "sim material"
printf 'an earlier export\n' > "$disk/m.axf"
# All but about 20 KiB: less than any of these outputs needs.
dd if=/dev/zero of="$disk/fill" bs=1024 count=$(( $(df -k "$disk" | awk 'NR == 2 {print $4}') - 20 )) 2> /dev/null
expect_refused m.axf "$loom" export "$work/material/svbrdf.exr" --axf "$disk/m.axf"
[ "$(cat "$disk/m.axf")" = "an earlier export" ] || fail "m.axf: the earlier file was changed"
expect_refused gltf "$loom" export "$work/material/svbrdf.exr" --gltf "$disk/gltf"
expect_refused model "$loom" model "$model" --out "$disk/model"
[ "$failures" = 0 ] && echo "full-disk outputs: all refused cleanly"
[ "$failures" = 0 ]
