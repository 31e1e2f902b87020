#include "scan/rig_state.h"

#include <charconv>
#include <cmath>
#include <set>

namespace loom::scan {
namespace {

// The whole of `text` as a number, or nothing.
template <typename T>
bool ParseWhole(std::string_view text, T& value) {
  const char* end = text.data() + text.size();
  const auto [stop, error] = std::from_chars(text.data(), end, value);
  return error == std::errc() && stop == end;
}

}  // namespace

Result<std::vector<LedDrive>> ParseLedDrives(std::string_view text, std::string_view what) {
  const auto problem = [&](std::string_view item, const std::string& why) {
    return InvalidArgumentError(std::string(what) + " '" + std::string(text) + "'",
                                "'" + std::string(item) + "': " + why + " (expected LED:MILLIAMPS[,LED:MILLIAMPS...])");
  };
  std::vector<LedDrive> drives;
  std::set<int> seen;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    const std::string_view item = text.substr(start, comma - start);
    start = comma + 1;
    const size_t colon = item.find(':');
    LedDrive drive;
    if (colon == std::string_view::npos) return problem(item, "no ':'");
    if (!ParseWhole(item.substr(0, colon), drive.led) || drive.led < 0)
      return problem(item, "the LED is not a whole number >= 0");
    if (!ParseWhole(item.substr(colon + 1), drive.current_ma) || !std::isfinite(drive.current_ma) || drive.current_ma < 0) {
      return problem(item, "the current is not a finite number of mA >= 0");
    }
    if (!seen.insert(drive.led).second) return problem(item, "LED " + std::to_string(drive.led) + " is given twice");
    drives.push_back(drive);
  }
  return drives;
}

}  // namespace loom::scan
