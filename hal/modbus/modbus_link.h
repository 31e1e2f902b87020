#pragma once
// ModbusLink: one Modbus connection (TCP or RTU) with loom's recovery policy, and errors that
// name the device (whose description includes the endpoint):
// - a response timeout or an invalid reply: late replies from a slow or frozen device would
//   answer the next requests, so TCP reconnects and RTU waits one timeout and flushes; then
//   one retry;
// - a reset connection (a restarted device): reconnect and retry once;
// - a Modbus exception from the device: no retry (it would answer the same).
// Thread-safe: requests are serialised (a device's watchdog heartbeat comes from its own thread).

#include <chrono>
#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <vector>

#include "core/status.h"

typedef struct _modbus modbus_t;

namespace loom::hal {

struct ModbusEndpoint {
  enum class Transport { kTcp, kRtu };
  Transport transport = Transport::kTcp;
  std::string host;    // TCP
  int port = 502;      // TCP
  std::string device;  // RTU: serial device path
  int baud = 115200;   // RTU
  char parity = 'N';   // RTU: N, E, O
  int data_bits = 8;   // RTU
  int stop_bits = 1;   // RTU
  int unit = 1;        // Modbus unit (slave) id

  std::string ToString() const;
};

// "tcp://127.0.0.1:1502[?unit=1]" or "rtu:///dev/ttyUSB0[?baud=115200&parity=N&unit=1]".
Result<ModbusEndpoint> ParseModbusEndpoint(const std::string& text);

class ModbusLink {
 public:
  // `device` names the device in every error (Device::description()).
  ModbusLink(std::string device, ModbusEndpoint endpoint, std::chrono::milliseconds response_timeout);
  ~ModbusLink();
  ModbusLink(const ModbusLink&) = delete;
  ModbusLink& operator=(const ModbusLink&) = delete;

  const ModbusEndpoint& endpoint() const { return endpoint_; }
  const std::string& device() const { return device_; }

  Status Connect();
  void Close();
  bool connected() const { return context_ != nullptr; }

  Result<std::vector<uint16_t>> Read(int address, int count);
  Result<uint16_t> Read(int address);
  Result<int32_t> Read32(int address);
  Status Write(int address, uint16_t value);
  Status Write(int address, std::span<const uint16_t> values);
  Status Write32(int address, int32_t value);

 private:
  template <typename Request>
  Status Transact(const std::string& what, Request request);
  Status Error(StatusCode code, const std::string& message) const;

  std::string device_;
  ModbusEndpoint endpoint_;
  std::chrono::milliseconds response_timeout_;
  modbus_t* context_ = nullptr;
  std::recursive_mutex mutex_;  // Transact reconnects through Connect
};

}  // namespace loom::hal
