#!/usr/bin/env bash
# Starts the protocol peers that configs/rig/peer.yaml talks to, all on 127.0.0.1, and stops
# them on Ctrl-C: three loom-modbus-sim controllers and one Aravis fake GigE camera.
# Build first (scripts/build.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
sim=build/hal/loom-modbus-sim
[[ -x $sim ]] || { echo "start-peers: build first (scripts/build.sh)" >&2; exit 1; }
pids=()
trap 'kill "${pids[@]}" 2>/dev/null; wait 2>/dev/null' EXIT INT TERM
"$sim" --device leds --tcp 127.0.0.1:15020 & pids+=($!)
"$sim" --device turntable --tcp 127.0.0.1:15021 & pids+=($!)
"$sim" --device linear-light --tcp 127.0.0.1:15022 & pids+=($!)
arv-fake-gv-camera-0.8 -i 127.0.0.1 -s PEERCAM0 & pids+=($!)
echo "peers running (pids ${pids[*]}); Ctrl-C stops them"
wait
