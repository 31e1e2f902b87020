#pragma once
// Number formatting for hal's messages and configure reports.
#include <sstream>
#include <string>

namespace loom::hal::internal {

inline std::string FormatNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

}  // namespace loom::hal::internal
