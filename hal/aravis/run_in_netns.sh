#!/bin/sh
# Runs a command inside a private network namespace that holds only a loopback interface with
# 127.0.0.1-127.0.0.4: the only place where loom's tests let Aravis discovery broadcast, and
# where four fake GigE cameras get an address each. The namespace vanishes with the command.
# Exits 77 (CTest's "skipped") where network namespaces cannot be created (not root).
if ! unshare -n true 2>/dev/null; then
  echo "run_in_netns: cannot create a network namespace here (needs root): skipped"
  exit 77
fi
exec unshare -n sh -c '
  ip link set lo up &&
  for i in 2 3 4; do ip addr add 127.0.0.$i/8 dev lo; done &&
  LOOM_IN_PRIVATE_NETNS=1 exec "$@"' run_in_netns "$@"
