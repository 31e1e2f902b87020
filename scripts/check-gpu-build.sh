#!/bin/bash
# Builds the GPU build here as a lent GPU machine builds it (docs/gpu-training.md): the packages
# `scripts/gpu-round.sh fetch` carries unpacked into a prefix, and Debian's own copies of them
# hidden in a private mount namespace (root), so that what the carried list lacks fails here.
# Then renders, fits (cnn+refine and ceres) and evaluates a 24² tac7-mini stack with it. Not a CI
# test: it compiles every fitting library once more (about 25 min on 2 cores from an empty cache).
#
#   bash scripts/check-gpu-build.sh [BUILD_DIR]     (default /tmp/loom-gpu-build-check)
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${1:-/tmp/loom-gpu-build-check}
if [ "${LOOM_IN_NAMESPACE:-}" != 1 ]; then
  [ "$(id -u)" = 0 ] || { echo "error: needs root (a private mount namespace hides Debian's copies)" >&2; exit 2; }
  compgen -G ".gpu-deps/*.deb" > /dev/null || { echo "error: no .gpu-deps/*.deb: run 'scripts/gpu-round.sh fetch' first" >&2; exit 2; }
  exec env LOOM_IN_NAMESPACE=1 unshare -m bash "$0" "$build_dir"
fi
prefix=$build_dir/deps
rm -rf "$prefix" && mkdir -p "$prefix" "$build_dir/empty"
for deb in .gpu-deps/*.deb; do dpkg -x "$deb" "$prefix"; done
# Every carried package's headers, CMake configs and libraries as Debian installs them here.
for dir in /usr/include/{ceres,opencv4,x86_64-linux-gnu/opencv4,glog,gflags,eigen3,yaml-cpp,CLI,nlohmann,OpenEXR,Imath,libpng16} \
  /usr/lib/x86_64-linux-gnu/cmake/{Ceres,opencv4,glog,gflags,yaml-cpp,OpenEXR,Imath} /usr/share/eigen3 \
  /usr/share/cmake/{nlohmann_json,CLI11}; do
  [ -e "$dir" ] && mount --bind "$build_dir/empty" "$dir"
done
for file in /usr/include/png{,conf,libconf}.h /usr/lib/x86_64-linux-gnu/lib{ceres,opencv_core,opencv_imgproc,glog,gflags,cholmod,spqr,cxsparse,png,yaml-cpp,OpenEXR,Imath}*; do
  [ -f "$file" ] && mount --bind /dev/null "$file"
done
libs=$prefix/usr/lib/x86_64-linux-gnu
export CMAKE_PREFIX_PATH="$prefix/usr" LD_LIBRARY_PATH="$libs:$libs/atlas"
cmake -S . -B "$build_dir/build" -G Ninja -DLOOM_GPU_BUILD=ON -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_PREFIX_PATH="$CMAKE_PREFIX_PATH" | grep -E "GPU build:"
cmake --build "$build_dir/build"
loom=$build_dir/build/apps/loom work=$build_dir/fit
"$loom" version
rm -rf "$work" && mkdir -p "$work"
"$loom" sim render --rig tac7-mini --stack --size 24 --truth "$work/truth.exr" --out "$work/stack.exr"
"$loom" fit "$work/stack.exr" --out "$work/cnn+refine" --quiet
"$loom" fit "$work/stack.exr" --method ceres --out "$work/ceres" --quiet
"$loom" eval "$work/cnn+refine/svbrdf.exr" --stack "$work/stack.exr" --reference "$work/truth.exr" --out "$work/eval" | tail -2
# What this build cannot do it refuses, naming why (no image codecs).
for refused in "sim capture --out $work/capture" \
  "eval $work/cnn+refine/svbrdf.exr --stack $work/stack.exr --reference-normals $work/truth.exr --out $work/eval-normals"; do
  # shellcheck disable=SC2086 # each line is one command's words
  if message=$("$loom" $refused 2>&1); then echo "FAIL: loom $refused did not fail"; exit 1; fi
  [[ $message == *"GPU build"* ]] || { echo "FAIL: loom $refused did not say why: $message"; exit 1; }
done
# What loom and the CNN's module load, and what the carried libraries load in turn, resolved in the
# prefix (Debian's CPU LibTorch here brings more of OpenCV; PyTorch's on a GPU machine does not).
missing=$(ldd "$loom" "$build_dir/build/fitting/cnn/torch/libloom_cnn_torch.so" | grep "not found" || true)
[ -z "$missing" ] || { echo "FAIL: libraries not found: $missing"; exit 1; }
outside=$(ldd "$libs"/lib{ceres.so.3,opencv_imgproc.so.406,png16.so.16,glog.so.1} |
  grep -E "not found|ceres|opencv|cholmod|spqr|glog|gflags|png16|atlas|blas|lapack|GLX|tbb" | grep -v "$prefix" || true)
[ -z "$outside" ] || { echo "FAIL: carried libraries' dependencies outside the prefix: $outside"; exit 1; }
echo "ok: the GPU build built from the carried packages alone, and fitted and evaluated a stack"
