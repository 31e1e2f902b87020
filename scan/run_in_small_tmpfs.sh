#!/bin/sh
# Runs a command with a 256 KiB tmpfs mounted at a fresh directory, in a private mount
# namespace (it disappears with the command): a disk that fills up, for full-disk tests.
# The directory is passed as LOOM_SMALL_TMPFS. Exits 77 (CTest's "skipped") without root.
dir=$(mktemp -d)
if ! unshare -m true 2>/dev/null; then
  echo "run_in_small_tmpfs: cannot create a mount namespace here (needs root): skipped"
  rmdir "$dir"
  exit 77
fi
unshare -m sh -c 'mount -t tmpfs -o size=256k tmpfs "$0" && LOOM_SMALL_TMPFS="$0" exec "$@"' "$dir" "$@"
status=$?
rmdir "$dir" 2>/dev/null
exit $status
