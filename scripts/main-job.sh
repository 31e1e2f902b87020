#!/usr/bin/env bash
# README command (1): installs what is needed, builds loom and runs the main job.
# For now the main job is `loom --help` (the simulated scan → fit → report arrives with the
# end-to-end issue, under this same command).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh loom
./build/apps/loom version
./build/apps/loom --help
