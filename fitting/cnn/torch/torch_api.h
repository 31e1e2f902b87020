#pragma once
// What differs between the LibTorch versions loom builds against, Debian 12's 1.13 (every CPU
// build and CI) and PyTorch's 2.x (the GPU build on GPU machines), in one place, so
// that the rest of the code is written once. Only a 2.x build can check the 2.x side: the GPU
// round's first stage is that build (scripts/gpu-round.sh, docs/gpu-training.md).

#include <torch/version.h>

#include <cstddef>
#include <cstring>

#include <c10/core/Allocator.h>

namespace loom::fitting::internal {

// c10::Allocator with the overrides its version declares: 1.13's `allocate` is const; 2.x's is
// not, and 2.x adds the pure virtual `copy_data`. A subclass implements Allocate.
class TensorAllocator : public c10::Allocator {
 public:
#if TORCH_VERSION_MAJOR >= 2
  c10::DataPtr allocate(size_t bytes) override { return Allocate(bytes); }
  void copy_data(void* dest, const void* src, std::size_t count) const override { std::memcpy(dest, src, count); }
#else
  c10::DataPtr allocate(size_t bytes) const override { return Allocate(bytes); }
#endif

 protected:
  virtual c10::DataPtr Allocate(size_t bytes) const = 0;
};

}  // namespace loom::fitting::internal
