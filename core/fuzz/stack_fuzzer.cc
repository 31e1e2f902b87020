// libFuzzer target: any bytes as an observation stack EXR (core/observation_stack.h,
// ReadObservationStack: OpenEXR's parsing, then loom's checks of the channels, the observation
// table, the pixel size, positions and normals). It must refuse or accept; never crash, hang or
// allocate without bound. Built with LOOM_BUILD_FUZZERS=ON under clang (scripts/fuzz.sh);
// seeded from stack-corpus/ (a 2 × 2 px stack of the tiny preset).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/observation_stack.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("loom_stack_fuzzer_" + std::to_string(::getpid()) + ".exr");
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  (void)loom::ReadObservationStack(path);
  return 0;
}
