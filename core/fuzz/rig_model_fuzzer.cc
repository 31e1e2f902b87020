// libFuzzer target: any bytes as a rig YAML's text, through the one reader of rig files and the
// rig model's validation (core/rig_file.h). It must refuse or accept; never crash, hang or
// allocate without bound. Built with LOOM_BUILD_FUZZERS=ON under clang (scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "core/rig_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  (void)loom::RigModelFromText(text, "fuzzed rig");
  return 0;
}
