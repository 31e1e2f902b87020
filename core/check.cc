#include "core/check.h"

namespace loom::internal {

CheckMessage::CheckMessage(const char* file, int line, const char* condition) {
  stream_ << file << ":" << line << ": check failed: " << condition << " ";
}

void CheckThrower::operator&(const CheckMessage& message) const { throw CheckError(message.str()); }

}  // namespace loom::internal
