#!/usr/bin/env bash
# Installs exactly the Debian 12 packages loom builds, tests and runs with, and the node packages
# of web/ (pinned by web/package-lock.json, from the npm registry).
# Idempotent: when everything is present it only checks and returns in a second or two.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(
  # toolchain
  cmake ninja-build g++ pkg-config ccache iproute2 clang-format
  # scripts/fuzz.sh: libFuzzer's clang with its runtime (ASan, UBSan, the fuzzer)
  clang libclang-rt-14-dev
  # hardware backends
  libaravis-dev aravis-tools libusb-1.0-0-dev libmodbus-dev
  # algorithms and data
  libopencv-dev libpng-dev libceres-dev libopenexr-dev libtorch-dev libopenblas0-pthread
  libeigen3-dev libyaml-cpp-dev nlohmann-json3-dev libcli11-dev libhdf5-dev zlib1g-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev umockdev libumockdev-dev xvfb
  # the browser side (web/): three.js renders in headless Chromium; blender/: Cycles renders
  # (Blender's glTF importer needs numpy, which Debian's blender does not pull in)
  chromium blender python3-numpy
  # scripts/slurm-fit-array.sh's test runs a single-node Slurm
  slurm-wlm munge
)
# Node.js and npm: Debian's, unless the machine has its own (as NodeSource's, which bundles npm).
command -v npm >/dev/null || packages+=(nodejs npm)

# web/node_modules as web/package-lock.json pins it; npm ci reinstalls only when the lock changed.
install_node_packages() {
  if [[ web/node_modules/.package-lock.json -nt web/package-lock.json ]]; then return; fi
  (cd web && npm ci --no-audit --no-fund --loglevel=error)
  echo "install-deps: installed web/'s node packages"
}

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages present"
  install_node_packages
  exit 0
fi

if [[ $(id -u) -ne 0 ]]; then
  echo "install-deps: missing packages: ${missing[*]} (run as root to install them)" >&2
  exit 1
fi

export DEBIAN_FRONTEND=noninteractive
# apt's lists can be locked for a moment by another apt run: retry a few times.
for attempt in 1 2 3 4 5; do
  if apt-get update -qq; then break; fi
  echo "install-deps: apt-get update failed (attempt $attempt), retrying in 5 s" >&2
  sleep 5
done
apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "install-deps: installed ${#missing[@]} packages"
install_node_packages
