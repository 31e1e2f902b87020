#include "core/status.h"

#include "core/check.h"

namespace loom {

std::string_view StatusCodeName(StatusCode code) {
  switch (code) {
    case StatusCode::kOk:
      return "ok";
    case StatusCode::kInvalidArgument:
      return "invalid argument";
    case StatusCode::kNotFound:
      return "not found";
    case StatusCode::kAlreadyExists:
      return "already exists";
    case StatusCode::kFailedPrecondition:
      return "failed precondition";
    case StatusCode::kOutOfRange:
      return "out of range";
    case StatusCode::kDataLoss:
      return "data loss";
    case StatusCode::kIoError:
      return "i/o error";
    case StatusCode::kTimeout:
      return "timeout";
    case StatusCode::kUnavailable:
      return "unavailable";
    case StatusCode::kCancelled:
      return "cancelled";
    case StatusCode::kUnimplemented:
      return "unimplemented";
    case StatusCode::kInternal:
      return "internal";
  }
  return "unknown";
}

Status::Status(StatusCode code, std::string subject, std::string message)
    : code_(code), subject_(std::move(subject)), message_(std::move(message)) {}

std::string Status::ToString() const {
  if (ok()) return "ok";
  std::string out(StatusCodeName(code_));
  out += ": ";
  if (!subject_.empty()) {
    out += subject_;
    out += ": ";
  }
  out += message_;
  return out;
}

Status Status::WithContext(std::string_view context) const {
  if (ok()) return *this;
  return Status(code_, subject_, std::string(context) + ": " + message_);
}

#define LOOM_DEFINE_STATUS_FACTORY(Name, code)                               \
  Status Name(std::string subject, std::string message) {                    \
    return Status(StatusCode::code, std::move(subject), std::move(message)); \
  }
LOOM_DEFINE_STATUS_FACTORY(InvalidArgumentError, kInvalidArgument)
LOOM_DEFINE_STATUS_FACTORY(NotFoundError, kNotFound)
LOOM_DEFINE_STATUS_FACTORY(AlreadyExistsError, kAlreadyExists)
LOOM_DEFINE_STATUS_FACTORY(FailedPreconditionError, kFailedPrecondition)
LOOM_DEFINE_STATUS_FACTORY(OutOfRangeError, kOutOfRange)
LOOM_DEFINE_STATUS_FACTORY(DataLossError, kDataLoss)
LOOM_DEFINE_STATUS_FACTORY(IoError, kIoError)
LOOM_DEFINE_STATUS_FACTORY(TimeoutError, kTimeout)
LOOM_DEFINE_STATUS_FACTORY(UnavailableError, kUnavailable)
LOOM_DEFINE_STATUS_FACTORY(CancelledError, kCancelled)
LOOM_DEFINE_STATUS_FACTORY(UnimplementedError, kUnimplemented)
LOOM_DEFINE_STATUS_FACTORY(InternalError, kInternal)

Status ProblemsStatus(std::string subject, const std::vector<std::string>& problems) {
  if (problems.empty()) return Status::Ok();
  std::string message;
  for (const std::string& problem : problems) message += (message.empty() ? "" : "; ") + problem;
  return InvalidArgumentError(std::move(subject), std::move(message));
}
#undef LOOM_DEFINE_STATUS_FACTORY

namespace internal {

void ThrowBadResultAccess(const Status& status) { throw CheckError("value() of a failed Result: " + status.ToString()); }

void ThrowOkStatusInResult() { throw CheckError("Result constructed from an OK status without a value"); }

}  // namespace internal
}  // namespace loom
