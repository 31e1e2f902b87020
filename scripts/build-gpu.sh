#!/bin/bash
# Builds the GPU build's `loom` (LOOM_GPU_BUILD: fit, train, model, eval and sim, docs/gpu-training.md)
# into build-gpu/ against the LibTorch of the python3 that has PyTorch — on a GPU machine,
# PyTorch's CUDA build, so that `loom train` and `loom fit` run the CNN there with `--device cuda`.
# Needs cmake, ninja, a C and C++ compiler and the headers of Eigen 3.4, yaml-cpp, nlohmann-json,
# CLI11, OpenEXR 3, HDF5, libpng, glog, Ceres and OpenCV's core and imgproc, with the libraries of
# the last three (Debian 12: scripts/gpu-round.sh's package list). Extra CMake prefixes (where those
# are unpacked) may come in CMAKE_PREFIX_PATH.
set -euo pipefail
cd "$(dirname "$0")/.."
torch_prefix=$(python3 -c 'import torch; print(torch.utils.cmake_prefix_path)') ||
  { echo "error: no PyTorch in python3: its LibTorch is what the GPU build builds against" >&2; exit 1; }
cmake -S . -B build-gpu -G Ninja -DLOOM_GPU_BUILD=ON -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="${CMAKE_PREFIX_PATH:+$CMAKE_PREFIX_PATH;}$torch_prefix" -DCMAKE_POLICY_VERSION_MINIMUM=3.5
cmake --build build-gpu
build-gpu/apps/loom version
