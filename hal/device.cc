#include "hal/device.h"

#include <algorithm>

namespace loom::hal {

std::string_view DeviceStateName(DeviceState state) {
  switch (state) {
    case DeviceState::kClosed:
      return "closed";
    case DeviceState::kOpen:
      return "open";
    case DeviceState::kConfigured:
      return "configured";
    case DeviceState::kRunning:
      return "running";
  }
  return "unknown";
}

std::string_view NegotiationName(Negotiation negotiation) {
  switch (negotiation) {
    case Negotiation::kValid:
      return "valid";
    case Negotiation::kAdjusted:
      return "adjusted";
    case Negotiation::kInvalid:
      return "invalid";
  }
  return "unknown";
}

void ConfigureReport::Adjust(std::string setting, std::string requested, std::string applied, std::string reason) {
  adjustments.push_back({std::move(setting), std::move(requested), std::move(applied), std::move(reason)});
  if (outcome == Negotiation::kValid) outcome = Negotiation::kAdjusted;
}

void ConfigureReport::Reject(std::string problem) {
  problems.push_back(std::move(problem));
  outcome = Negotiation::kInvalid;
}

std::string ConfigureReport::ToString() const {
  std::string out(NegotiationName(outcome));
  for (const Adjustment& a : adjustments) {
    out += "\n  " + a.setting + ": " + a.requested + " -> " + a.applied + " (" + a.reason + ")";
  }
  for (const std::string& problem : problems) out += "\n  " + problem;
  return out;
}

Status ConfigureReport::ToStatus(const std::string& device) const {
  if (outcome != Negotiation::kInvalid) return Status::Ok();
  std::string message = "configuration rejected:";
  for (const std::string& problem : problems) message += " " + problem + ";";
  message.pop_back();
  return InvalidArgumentError(device, message);
}

Device::Device(std::string kind, std::string name, std::string backend, std::string address)
    : kind_(std::move(kind)), name_(std::move(name)), backend_(std::move(backend)), address_(std::move(address)) {
  description_ = kind_ + " '" + name_ + "' (" + backend_ + (address_.empty() ? "" : " " + address_) + ")";
}

Status Device::ExpectState(std::initializer_list<DeviceState> allowed, std::string_view call) const {
  if (std::find(allowed.begin(), allowed.end(), state_) != allowed.end()) return Status::Ok();
  std::string expected;
  for (DeviceState s : allowed) expected += (expected.empty() ? "" : " or ") + std::string(DeviceStateName(s));
  return FailedPreconditionError(description_, std::string(call) + "() needs the device " + expected + ", but it is " +
                                                   std::string(DeviceStateName(state_)));
}

Status Device::Error(StatusCode code, std::string message) const { return Status(code, description_, std::move(message)); }

Status Device::Open() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kClosed}, "Open"));
  LOOM_ASSIGN_OR_RETURN(identity_, DoOpen());
  state_ = DeviceState::kOpen;
  return Status::Ok();
}

Status Device::Start() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kConfigured}, "Start"));
  LOOM_RETURN_IF_ERROR(DoStart());
  state_ = DeviceState::kRunning;
  return Status::Ok();
}

Status Device::Stop() {
  LOOM_RETURN_IF_ERROR(ExpectState({DeviceState::kRunning}, "Stop"));
  const Status stopped = DoStop();
  // Even a failed stop leaves the device not running as far as loom is concerned: the caller
  // decides whether to retry Start() or Close().
  state_ = DeviceState::kConfigured;
  return stopped;
}

Status Device::Close() {
  if (state_ == DeviceState::kClosed) return Status::Ok();
  Status first = Status::Ok();
  if (state_ == DeviceState::kRunning) first = DoStop();
  const Status closed = DoClose();
  if (first.ok()) first = closed;
  state_ = DeviceState::kClosed;
  return first;
}

Status Device::MakeSafe() {
  if (state_ == DeviceState::kClosed) return Status::Ok();
  return DoMakeSafe();
}

}  // namespace loom::hal
