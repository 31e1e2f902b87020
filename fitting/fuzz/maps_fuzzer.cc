// libFuzzer target: any bytes as fitted maps (fitting/report/export.h, ReadSvbrdf): an OpenEXR svbrdf
// file, or an AxF file (HDF5, fitting/io/axf_export.h) when the bytes start with HDF5's signature.
// It must refuse or accept; never crash, hang or allocate without bound. Built with
// LOOM_BUILD_FUZZERS=ON under clang (scripts/fuzz.sh); seeded from maps-corpus/ (8 × 8 px maps
// of a procedural fabric, as svbrdf.exr and as material.axf).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "fitting/report/export.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string stem =
      (std::filesystem::temp_directory_path() / ("loom_maps_fuzzer_" + std::to_string(::getpid()))).string();
  constexpr char kHdf5Signature[] = "\x89HDF\r\n\x1a\n";
  const bool axf = size >= 8 && std::memcmp(data, kHdf5Signature, 8) == 0;
  const std::filesystem::path path = stem + (axf ? ".axf" : ".exr");
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  (void)loom::fitting::ReadSvbrdf(path);
  return 0;
}
