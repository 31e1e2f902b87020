#pragma once
// Status and Result<T>: how loom reports *expected* failures (a missing file, a bad config key,
// a device timeout). Every non-OK status names its subject — the file, config key or device the
// failure is about — so that a user can act on the message alone:
//
//   not found: /data/scan/frame_0012.png: no such file
//   invalid argument: configs/rig/tac7.yaml: key 'cameras[2].exposur_us': unknown key
//
// Broken invariants (programming errors) are not statuses: they throw from LOOM_CHECK (check.h).
// Thread-safety: value types; no shared state.

#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

namespace loom {

enum class StatusCode {
  kOk,
  kInvalidArgument,     // bad input: config key, command-line value, malformed file content
  kNotFound,            // a file, key, device or channel that should exist does not
  kAlreadyExists,       // refusing to overwrite
  kFailedPrecondition,  // call in the wrong state (device lifecycle), missing prior step
  kOutOfRange,          // value outside what a device or model accepts
  kDataLoss,            // corrupt or truncated data (checksum mismatch, truncated EXR)
  kIoError,             // the OS refused a read/write (full disk, permissions)
  kTimeout,             // a device or peer did not answer in time
  kUnavailable,         // a device dropped out or cannot be reached
  kCancelled,           // the user interrupted (Ctrl-C)
  kUnimplemented,       // not built yet; the message says which issue tracks it
  kInternal,            // a failure inside a dependency that fits no other code
};

std::string_view StatusCodeName(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;  // OK
  Status(StatusCode code, std::string subject, std::string message);

  static Status Ok() { return Status(); }

  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  // The file, key or device the failure is about (may be empty for OK).
  const std::string& subject() const { return subject_; }
  const std::string& message() const { return message_; }

  // "code: subject: message", or "ok".
  std::string ToString() const;

  // Returns a copy whose message is prefixed with `context` ("while loading rig: ...").
  // The subject stays the most specific one (the file or key that actually failed).
  Status WithContext(std::string_view context) const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string subject_;
  std::string message_;
};

// Factories, one per code: e.g. NotFoundError(path, "no such file").
Status InvalidArgumentError(std::string subject, std::string message);
Status NotFoundError(std::string subject, std::string message);
Status AlreadyExistsError(std::string subject, std::string message);
Status FailedPreconditionError(std::string subject, std::string message);
Status OutOfRangeError(std::string subject, std::string message);
Status DataLossError(std::string subject, std::string message);
Status IoError(std::string subject, std::string message);
Status TimeoutError(std::string subject, std::string message);
Status UnavailableError(std::string subject, std::string message);
Status CancelledError(std::string subject, std::string message);
Status UnimplementedError(std::string subject, std::string message);
Status InternalError(std::string subject, std::string message);

// What an options struct's Check() returns: Ok without problems, else InvalidArgument naming
// `subject` with every problem, joined by "; ".
Status ProblemsStatus(std::string subject, const std::vector<std::string>& problems);

// Result<T>: a value or a non-OK Status.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::move(value)) {}  // NOLINT: implicit by design
  Result(Status status);                         // NOLINT: must not be OK

  bool ok() const { return std::holds_alternative<T>(state_); }
  // OK status when a value is held.
  Status status() const { return ok() ? Status() : std::get<Status>(state_); }

  // Accessors CHECK that a value is held (see check.h): reading a failed result is a bug.
  T& value() &;
  const T& value() const&;
  T&& value() &&;
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T&& operator*() && { return std::move(*this).value(); }

 private:
  std::variant<T, Status> state_;
};

namespace internal {
[[noreturn]] void ThrowBadResultAccess(const Status& status);
[[noreturn]] void ThrowOkStatusInResult();
}  // namespace internal

template <typename T>
Result<T>::Result(Status status) : state_(std::move(status)) {
  if (std::get<Status>(state_).ok()) internal::ThrowOkStatusInResult();
}

template <typename T>
T& Result<T>::value() & {
  if (!ok()) internal::ThrowBadResultAccess(std::get<Status>(state_));
  return std::get<T>(state_);
}

template <typename T>
const T& Result<T>::value() const& {
  if (!ok()) internal::ThrowBadResultAccess(std::get<Status>(state_));
  return std::get<T>(state_);
}

template <typename T>
T&& Result<T>::value() && {
  if (!ok()) internal::ThrowBadResultAccess(std::get<Status>(state_));
  return std::get<T>(std::move(state_));
}

}  // namespace loom

#define LOOM_STATUS_CONCAT_INNER(a, b) a##b
#define LOOM_STATUS_CONCAT(a, b) LOOM_STATUS_CONCAT_INNER(a, b)

// Returns the status from the enclosing function if `expr` is not OK.
#define LOOM_RETURN_IF_ERROR(expr)               \
  do {                                           \
    ::loom::Status loom_status_ = (expr);        \
    if (!loom_status_.ok()) return loom_status_; \
  } while (false)

// `LOOM_ASSIGN_OR_RETURN(auto image, ReadExr(path));` — declares/assigns on success,
// returns the status from the enclosing function on failure.
#define LOOM_ASSIGN_OR_RETURN(lhs, expr) LOOM_ASSIGN_OR_RETURN_IMPL(LOOM_STATUS_CONCAT(loom_result_, __LINE__), lhs, expr)
#define LOOM_ASSIGN_OR_RETURN_IMPL(result, lhs, expr) \
  auto result = (expr);                               \
  if (!result.ok()) return result.status();           \
  lhs = std::move(result).value()
