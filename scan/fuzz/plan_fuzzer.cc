// libFuzzer target: any bytes as a scan's plan.yaml (scan/plan.h, ParsePlanYaml). It must refuse
// or accept; never crash, hang or allocate without bound. Built with LOOM_BUILD_FUZZERS=ON under
// clang (scripts/fuzz.sh).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "scan/plan.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  (void)loom::scan::ParsePlanYaml(text, "fuzzed plan.yaml");
  return 0;
}
