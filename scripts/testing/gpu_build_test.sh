#!/bin/bash
# The GPU build (LOOM_GPU_BUILD, docs/gpu-training.md) configures, and its `loom` links the fitters,
# the CNN's library and the trainer, Ceres and OpenCV's core found by their files (as on a GPU
# machine, from carried Debian packages), and none of the image codecs, photographs, calibration
# or device libraries.
# Usage: gpu_build_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
source_dir=$1 build_dir=$2
rm -rf "$build_dir"
cmake -S "$source_dir" -B "$build_dir" -G Ninja -DLOOM_GPU_BUILD=ON > "$build_dir.log" 2>&1 ||
  { cat "$build_dir.log"; echo "FAIL: the GPU build does not configure"; exit 1; }
link=$(grep -A3 '^build apps/loom:' "$build_dir/build.ninja" | grep -m1 'LINK_LIBRARIES')
for wanted in libloom_fitting.a libloom_fitting_solve.a libloom_fitting_report.a libloom_fitting_cnn.a \
  libloom_training.a libloom_sim.a libceres.so.3 libglog libopencv_core.so.406 libopencv_imgproc.so.406 libpng libtorch; do
  [[ $link == *"$wanted"* ]] || { echo "FAIL: loom does not link $wanted: $link"; exit 1; }
done
# libstdc++ before LibTorch, so that PyTorch's exported copy of std::filesystem does not
# interpose (apps/CMakeLists.txt).
stdcxx=${link%%-lstdc++*} torch=${link%%libtorch*}
(( ${#stdcxx} < ${#torch} )) || { echo "FAIL: loom links LibTorch before libstdc++: $link"; exit 1; }
# The CNN's LibTorch side, which loom loads when it trains or fits (fitting/cnn/internal/cnn_engine.h).
grep -q '^build fitting/cnn/torch/libloom_cnn_torch.so:' "$build_dir/build.ninja" ||
  { echo "FAIL: the GPU build has no CNN module (fitting/cnn/torch/libloom_cnn_torch.so)"; exit 1; }
for unwanted in imgcodecs calib3d highgui aravis modbus libusb loom_hal loom_acquisition loom_photos loom_calibration \
  loom_reconstruction loom_demo; do
  [[ $link != *"$unwanted"* ]] || { echo "FAIL: the GPU build's loom links $unwanted: $link"; exit 1; }
done
echo "ok: the GPU build's loom links libstdc++ first, the fitters, the CNN and the trainer, and none of the image codecs, photographs or devices; the CNN module builds"
