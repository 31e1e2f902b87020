#!/bin/bash
# Builds the trainer-only `loom` (LOOM_TRAINER_ONLY: `loom train` alone, docs/gpu-training.md)
# into build-trainer/ against the LibTorch of the python3 that has PyTorch — on a GPU machine,
# PyTorch's CUDA build, so that `loom train --device cuda` trains on the GPU.
# Needs cmake, ninja, a C and C++ compiler and the headers of Eigen 3.4, yaml-cpp, nlohmann-json,
# CLI11, OpenEXR 3 and HDF5 (Debian/Ubuntu: libeigen3-dev libyaml-cpp-dev nlohmann-json3-dev
# libcli11-dev libopenexr-dev libhdf5-dev). Extra CMake prefixes (where those are unpacked) may
# come in CMAKE_PREFIX_PATH.
set -euo pipefail
cd "$(dirname "$0")/.."
torch_prefix=$(python3 -c 'import torch; print(torch.utils.cmake_prefix_path)') ||
  { echo "error: no PyTorch in python3: its LibTorch is what the trainer builds against" >&2; exit 1; }
cmake -S . -B build-trainer -G Ninja -DLOOM_TRAINER_ONLY=ON -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="${CMAKE_PREFIX_PATH:+$CMAKE_PREFIX_PATH;}$torch_prefix" -DCMAKE_POLICY_VERSION_MINIMUM=3.5
cmake --build build-trainer
build-trainer/apps/loom version
