#include "hal/modbus/modbus_link.h"

#include <modbus.h>

#include <cerrno>
#include <charconv>
#include <map>
#include <thread>

#include "core/log.h"

namespace loom::hal {
namespace {

std::map<std::string, std::string> ParseQuery(std::string_view query) {
  std::map<std::string, std::string> values;
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    const size_t eq = pair.find('=');
    values[std::string(pair.substr(0, eq))] = eq == std::string_view::npos ? "" : std::string(pair.substr(eq + 1));
    if (amp == std::string_view::npos) break;
    query.remove_prefix(amp + 1);
  }
  return values;
}

bool ParseInt(const std::string& text, int* out) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), *out);
  return ec == std::errc() && end == text.data() + text.size();
}

bool IsConnectionLost(int error) {
  return error == EPIPE || error == ECONNRESET || error == EBADF || error == ENOTCONN || error == ECONNREFUSED || error == EIO;
}

std::string_view ExceptionMeaning(int error) {
  switch (error) {
    case EMBXILFUN:
      return "illegal function";
    case EMBXILADD:
      return "illegal register address";
    case EMBXILVAL:
      return "illegal value (refused by the device)";
    case EMBXSFAIL:
      return "device failure";
    case EMBXSBUSY:
      return "device busy";
    default:
      return "exception";
  }
}

}  // namespace

std::string ModbusEndpoint::ToString() const {
  if (transport == Transport::kTcp) {
    return "tcp://" + host + ":" + std::to_string(port) + "?unit=" + std::to_string(unit);
  }
  return "rtu://" + device + "?baud=" + std::to_string(baud) + "&parity=" + std::string(1, parity) +
         "&unit=" + std::to_string(unit);
}

Result<ModbusEndpoint> ParseModbusEndpoint(const std::string& text) {
  const auto invalid = [&](const std::string& why) {
    return InvalidArgumentError("endpoint '" + text + "'", why + " (expected tcp://HOST:PORT or rtu:///dev/ttyX?baud=N)");
  };
  ModbusEndpoint endpoint;
  std::string_view rest = text;
  if (rest.starts_with("tcp://")) {
    rest.remove_prefix(6);
  } else if (rest.starts_with("rtu://")) {
    endpoint.transport = ModbusEndpoint::Transport::kRtu;
    rest.remove_prefix(6);
  } else {
    return invalid("unknown transport");
  }
  const size_t question = rest.find('?');
  const std::string_view where = rest.substr(0, question);
  const auto query = ParseQuery(question == std::string_view::npos ? "" : rest.substr(question + 1));
  for (const auto& [key, value] : query) {
    bool ok = false;
    if (key == "unit") {
      ok = ParseInt(value, &endpoint.unit);
    } else if (key == "baud") {
      ok = ParseInt(value, &endpoint.baud);
    } else if (key == "parity") {
      ok = value == "N" || value == "E" || value == "O";
      if (ok) endpoint.parity = value[0];
    } else if (key == "data_bits") {
      ok = ParseInt(value, &endpoint.data_bits);
    } else if (key == "stop_bits") {
      ok = ParseInt(value, &endpoint.stop_bits);
    }
    if (!ok) return invalid("bad parameter '" + key + "=" + value + "'");
  }
  if (endpoint.transport == ModbusEndpoint::Transport::kTcp) {
    const size_t colon = where.rfind(':');
    if (colon == std::string_view::npos || colon == 0) return invalid("missing host or port");
    endpoint.host = std::string(where.substr(0, colon));
    if (!ParseInt(std::string(where.substr(colon + 1)), &endpoint.port) || endpoint.port <= 0 || endpoint.port > 65535) {
      return invalid("bad port");
    }
  } else {
    if (where.empty() || where[0] != '/') return invalid("missing serial device path");
    endpoint.device = std::string(where);
  }
  return endpoint;
}

ModbusLink::ModbusLink(std::string device, ModbusEndpoint endpoint, std::chrono::milliseconds response_timeout)
    : device_(std::move(device)), endpoint_(std::move(endpoint)), response_timeout_(response_timeout) {}

ModbusLink::~ModbusLink() { Close(); }

Status ModbusLink::Error(StatusCode code, const std::string& message) const { return Status(code, device_, message); }

Status ModbusLink::Connect() {
  const std::lock_guard<std::recursive_mutex> lock(mutex_);
  Close();
  modbus_t* context =
      endpoint_.transport == ModbusEndpoint::Transport::kTcp
          ? modbus_new_tcp(endpoint_.host.c_str(), endpoint_.port)
          : modbus_new_rtu(endpoint_.device.c_str(), endpoint_.baud, endpoint_.parity, endpoint_.data_bits, endpoint_.stop_bits);
  if (context == nullptr) {
    return Error(StatusCode::kInvalidArgument, std::string("cannot create Modbus context: ") + modbus_strerror(errno));
  }
  modbus_set_slave(context, endpoint_.unit);
  const auto micros = std::chrono::duration_cast<std::chrono::microseconds>(response_timeout_).count();
  modbus_set_response_timeout(context, static_cast<uint32_t>(micros / 1000000), static_cast<uint32_t>(micros % 1000000));
  if (modbus_connect(context) == -1) {
    const int error = errno;
    modbus_free(context);
    return Error(StatusCode::kUnavailable, std::string("cannot connect: ") + modbus_strerror(error));
  }
  context_ = context;
  return Status::Ok();
}

void ModbusLink::Close() {
  const std::lock_guard<std::recursive_mutex> lock(mutex_);
  if (context_ == nullptr) return;
  modbus_close(context_);
  modbus_free(context_);
  context_ = nullptr;
}

template <typename Request>
Status ModbusLink::Transact(const std::string& what, Request request) {
  const std::lock_guard<std::recursive_mutex> lock(mutex_);
  Status last;
  for (int attempt = 0; attempt < 2; ++attempt) {
    if (context_ == nullptr) {
      last = Connect();
      if (!last.ok()) continue;
    }
    errno = 0;
    if (request(context_) != -1) return Status::Ok();
    const int error = errno;
    if (error == ETIMEDOUT || error == EMBBADDATA || error == EMBBADCRC) {
      // Replies that come late (a slow or frozen device) would answer the next requests.
      // Over TCP a new connection leaves them behind; on a serial line, wait them out and
      // discard them.
      last = Error(error == ETIMEDOUT ? StatusCode::kTimeout : StatusCode::kDataLoss,
                   what + ": " +
                       (error == ETIMEDOUT ? "no reply within " + std::to_string(response_timeout_.count()) + " ms"
                                           : std::string("invalid reply (") + modbus_strerror(error) + ")"));
      if (endpoint_.transport == ModbusEndpoint::Transport::kTcp) {
        Close();
      } else {
        std::this_thread::sleep_for(response_timeout_);
        modbus_flush(context_);
      }
    } else if (IsConnectionLost(error)) {
      Close();
      last = Error(StatusCode::kUnavailable, what + ": connection lost: " + modbus_strerror(error));
    } else if (error > MODBUS_ENOBASE && error <= EMBXGTAR) {
      // The device answered with an exception: retrying would get the same answer.
      return Error(error == EMBXILVAL ? StatusCode::kInvalidArgument : StatusCode::kUnavailable,
                   what + ": " + std::string(ExceptionMeaning(error)));
    } else {
      return Error(StatusCode::kIoError, what + ": " + modbus_strerror(error));
    }
    if (attempt == 0) LOOM_LOG(Warning) << last.ToString() << "; retrying once";
  }
  return last;
}

Result<std::vector<uint16_t>> ModbusLink::Read(int address, int count) {
  std::vector<uint16_t> values(count);
  LOOM_RETURN_IF_ERROR(Transact("reading registers " + std::to_string(address) + ".." + std::to_string(address + count - 1),
                                [&](modbus_t* c) { return modbus_read_registers(c, address, count, values.data()); }));
  return values;
}

Result<uint16_t> ModbusLink::Read(int address) {
  LOOM_ASSIGN_OR_RETURN(const std::vector<uint16_t> values, Read(address, 1));
  return values[0];
}

Result<int32_t> ModbusLink::Read32(int address) {
  LOOM_ASSIGN_OR_RETURN(const std::vector<uint16_t> values, Read(address, 2));
  return static_cast<int32_t>((static_cast<uint32_t>(values[0]) << 16) | values[1]);
}

Status ModbusLink::Write(int address, uint16_t value) {
  return Transact("writing register " + std::to_string(address),
                  [&](modbus_t* c) { return modbus_write_register(c, address, value); });
}

Status ModbusLink::Write(int address, std::span<const uint16_t> values) {
  return Transact(
      "writing registers " + std::to_string(address) + ".." + std::to_string(address + static_cast<int>(values.size()) - 1),
      [&](modbus_t* c) { return modbus_write_registers(c, address, static_cast<int>(values.size()), values.data()); });
}

Status ModbusLink::Write32(int address, int32_t value) {
  const uint32_t bits = static_cast<uint32_t>(value);
  const uint16_t words[2] = {static_cast<uint16_t>(bits >> 16), static_cast<uint16_t>(bits & 0xFFFF)};
  return Write(address, words);
}

}  // namespace loom::hal
