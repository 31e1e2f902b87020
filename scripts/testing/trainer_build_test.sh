#!/bin/bash
# The trainer-only build (LOOM_TRAINER_ONLY, docs/gpu-training.md) configures, and its `loom`
# links the CNN's library but none of Ceres, OpenCV or the device libraries (glog comes with
# Debian's LibTorch).
# Usage: trainer_build_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
source_dir=$1 build_dir=$2
rm -rf "$build_dir"
cmake -S "$source_dir" -B "$build_dir" -G Ninja -DLOOM_TRAINER_ONLY=ON > "$build_dir.log" 2>&1 ||
  { cat "$build_dir.log"; echo "FAIL: the trainer-only build does not configure"; exit 1; }
link=$(grep -A3 '^build apps/loom:' "$build_dir/build.ninja" | grep -m1 'LINK_LIBRARIES')
for wanted in libloom_fitting_cnn.a libloom_sim.a libtorch; do
  [[ $link == *"$wanted"* ]] || { echo "FAIL: loom does not link $wanted: $link"; exit 1; }
done
# libstdc++ before LibTorch, so that PyTorch's exported copy of std::filesystem does not
# interpose (apps/CMakeLists.txt).
stdcxx=${link%%-lstdc++*} torch=${link%%libtorch*}
(( ${#stdcxx} < ${#torch} )) || { echo "FAIL: loom links LibTorch before libstdc++: $link"; exit 1; }
# The CNN's LibTorch side, which loom loads when it trains (fitting/cnn/internal/cnn_engine.h).
grep -q '^build fitting/cnn/torch/libloom_cnn_torch.so:' "$build_dir/build.ninja" ||
  { echo "FAIL: the trainer-only build has no CNN module (fitting/cnn/torch/libloom_cnn_torch.so)"; exit 1; }
for unwanted in ceres opencv aravis modbus libusb libloom_fitting.a libloom_fitting_solve.a libloom_fitting_report.a loom_hal loom_acquisition; do
  [[ $link != *"$unwanted"* ]] || { echo "FAIL: the trainer-only loom links $unwanted: $link"; exit 1; }
done
echo "ok: the trainer-only loom links libstdc++ first, the CNN, and none of Ceres, OpenCV or the devices; the CNN module builds"
