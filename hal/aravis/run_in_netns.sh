#!/bin/sh
# Runs a command inside a private network namespace that holds only a loopback interface with
# 127.0.0.1-127.0.0.4: the only place where loom's tests let Aravis discovery broadcast, and
# where four fake GigE cameras get an address each. The namespace vanishes with the command.
# The command is also the first process of a PID namespace of its own: when it ends, crashed or
# aborted by a sanitizer included, the kernel kills every peer it started, so none is left to
# hold CTest's output pipe open or the fake cameras' addresses.
# Exits 77 (CTest's "skipped") where the namespaces cannot be created (not root).
if ! unshare -n -p -f true 2>/dev/null; then
  echo "run_in_netns: cannot create network and PID namespaces here (needs root): skipped"
  exit 77
fi
exec unshare -n -p -f --kill-child sh -c '
  ip link set lo up &&
  for i in 2 3 4; do ip addr add 127.0.0.$i/8 dev lo; done &&
  LOOM_IN_PRIVATE_NETNS=1 exec "$@"' run_in_netns "$@"
