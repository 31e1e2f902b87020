#pragma once
// LOOM_CHECK: invariants that only a bug can break. A failed check throws loom::CheckError
// (with file:line, the condition and an optional streamed message); the CLI catches it at the
// top, puts the rig in its safe state and exits 1. Expected failures (bad input, device
// timeouts) are never CHECKs: they return a Status (status.h).
//
//   LOOM_CHECK(width > 0) << "image " << name << " has no pixels";
//   LOOM_CHECK_EQ(a.size(), b.size());

#include <sstream>
#include <stdexcept>
#include <string>

namespace loom {

class CheckError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

namespace internal {

// Collects the message; operator& (lower precedence than <<) throws once it is complete.
class CheckMessage {
 public:
  CheckMessage(const char* file, int line, const char* condition);
  template <typename T>
  CheckMessage& operator<<(const T& value) {
    stream_ << value;
    return *this;
  }
  std::string str() const { return stream_.str(); }

 private:
  std::ostringstream stream_;
};

struct CheckThrower {
  [[noreturn]] void operator&(const CheckMessage& message) const;
};

template <typename A, typename B>
std::string FormatOperands(const A& a, const B& b) {
  std::ostringstream out;
  out << " (" << a << " vs " << b << ")";
  return out.str();
}

}  // namespace internal
}  // namespace loom

#define LOOM_CHECK(condition)        \
  (condition) ? static_cast<void>(0) \
              : ::loom::internal::CheckThrower() & ::loom::internal::CheckMessage(__FILE__, __LINE__, #condition)

#define LOOM_CHECK_OP(a, op, b)                                                                                         \
  ((a)op(b)) ? static_cast<void>(0)                                                                                     \
             : ::loom::internal::CheckThrower() & ::loom::internal::CheckMessage(__FILE__, __LINE__, #a " " #op " " #b) \
                                                      << ::loom::internal::FormatOperands((a), (b))

#define LOOM_CHECK_EQ(a, b) LOOM_CHECK_OP(a, ==, b)
#define LOOM_CHECK_NE(a, b) LOOM_CHECK_OP(a, !=, b)
#define LOOM_CHECK_LT(a, b) LOOM_CHECK_OP(a, <, b)
#define LOOM_CHECK_LE(a, b) LOOM_CHECK_OP(a, <=, b)
#define LOOM_CHECK_GT(a, b) LOOM_CHECK_OP(a, >, b)
#define LOOM_CHECK_GE(a, b) LOOM_CHECK_OP(a, >=, b)
