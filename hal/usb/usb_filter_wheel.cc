#include <libusb.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <thread>

#include "core/interrupt.h"
#include "hal/usb/filter_wheel_protocol.h"
#include "hal/usb/usb_backend.h"

namespace loom::hal {
namespace {

namespace proto = usb_wheel;
using Clock = std::chrono::steady_clock;

constexpr std::chrono::milliseconds kPollInterval(2);

struct UsbWheelOptions {
  std::string serial;
  int vendor_id = proto::kDefaultVendorId;
  int product_id = proto::kDefaultProductId;
  int request_timeout_ms = 500;
};

struct WheelStatus {
  int slot = 0;  // proto::kSlotMoving while moving
  bool busy = false;
  int error = 0;
  int slot_count = 0;
};

std::string Hex4(int value) {
  char text[8];
  std::snprintf(text, sizeof(text), "%04x", value & 0xFFFF);
  return text;
}

class UsbFilterWheel : public FilterWheel {
 public:
  UsbFilterWheel(const std::string& name, UsbWheelOptions options)
      : FilterWheel(name, "usb",
                    "usb:" + Hex4(options.vendor_id) + ":" + Hex4(options.product_id) +
                        (options.serial.empty() ? "" : "/" + options.serial)),
        options_(std::move(options)) {}
  ~UsbFilterWheel() override { Release(); }

 protected:
  Result<DeviceIdentity> DoOpen() override {
    if (const int rc = libusb_init(&context_); rc != 0) {
      context_ = nullptr;
      return UsbError(rc, "cannot initialise libusb");
    }
    LOOM_ASSIGN_OR_RETURN(DeviceIdentity identity, FindAndOpen());
    LOOM_ASSIGN_OR_RETURN(const WheelStatus status, ReadStatus());
    set_slot_count(status.slot_count);
    return identity;
  }
  Status DoConfigure(const FilterWheelSettings&) override { return Status::Ok(); }
  Status DoStart() override { return Status::Ok(); }
  Status DoStop() override { return Status::Ok(); }
  Status DoClose() override {
    Release();
    return Status::Ok();
  }
  // A wheel holds no energy worth removing; a move in progress ends at its slot.
  Status DoMakeSafe() override { return Status::Ok(); }

  Status DoMoveTo(int slot) override {
    LOOM_RETURN_IF_ERROR(Send(proto::kMove, static_cast<uint16_t>(slot), "move to slot " + std::to_string(slot)));
    const Clock::time_point deadline = Clock::now() + std::chrono::milliseconds(settings().move_timeout_ms);
    while (true) {
      LOOM_ASSIGN_OR_RETURN(const WheelStatus status, ReadStatus());
      if (status.error != proto::kErrorNone) {
        return Error(StatusCode::kUnavailable, "move to slot " + std::to_string(slot) + " failed: error " +
                                                   std::to_string(status.error) +
                                                   (status.error == proto::kErrorJammed ? " (jammed)" : ""));
      }
      if (!status.busy && status.slot == slot) return Status::Ok();
      if (InterruptRequested()) {
        return Error(StatusCode::kCancelled, "move to slot " + std::to_string(slot) + " interrupted");
      }
      if (Clock::now() > deadline) {
        return Error(StatusCode::kTimeout, "move to slot " + std::to_string(slot) + " did not complete within " +
                                               std::to_string(settings().move_timeout_ms) + " ms");
      }
      std::this_thread::sleep_for(kPollInterval);
    }
  }

  Result<int> DoPosition() override {
    LOOM_ASSIGN_OR_RETURN(const WheelStatus status, ReadStatus());
    if (status.busy) return Error(StatusCode::kFailedPrecondition, "the wheel is moving");
    return status.slot;
  }

 private:
  Status UsbError(int rc, const std::string& what) const {
    const StatusCode code = rc == LIBUSB_ERROR_NO_DEVICE ? StatusCode::kUnavailable
                            : rc == LIBUSB_ERROR_TIMEOUT ? StatusCode::kTimeout
                            : rc == LIBUSB_ERROR_PIPE    ? StatusCode::kInvalidArgument
                                                         : StatusCode::kIoError;
    std::string meaning = libusb_strerror(static_cast<libusb_error>(rc));
    if (rc == LIBUSB_ERROR_NO_DEVICE) meaning = "the wheel was unplugged or lost power";
    if (rc == LIBUSB_ERROR_PIPE) meaning = "the wheel refused the request (STALL)";
    return Error(code, what + ": " + meaning);
  }

  std::string ReadString(libusb_device_handle* handle, uint8_t index) {
    unsigned char text[128] = {};
    const int n = libusb_get_string_descriptor_ascii(handle, index, text, sizeof(text));
    return n > 0 ? std::string(reinterpret_cast<char*>(text), n) : "";
  }

  // Finds the wheel with our ids (and serial), opens it and claims interface 0.
  Result<DeviceIdentity> FindAndOpen() {
    libusb_device** list = nullptr;
    const ssize_t count = libusb_get_device_list(context_, &list);
    if (count < 0) return UsbError(static_cast<int>(count), "cannot list USB devices");
    std::vector<std::string> seen;
    Status failure = Error(StatusCode::kNotFound, "no filter wheel with these ids is connected");
    for (ssize_t i = 0; i < count && handle_ == nullptr; ++i) {
      libusb_device_descriptor descriptor;
      if (libusb_get_device_descriptor(list[i], &descriptor) != 0 || descriptor.idVendor != options_.vendor_id ||
          descriptor.idProduct != options_.product_id) {
        continue;
      }
      libusb_device_handle* handle = nullptr;
      if (const int rc = libusb_open(list[i], &handle); rc != 0) {
        failure = UsbError(rc, "cannot open the wheel");
        continue;
      }
      const std::string serial = ReadString(handle, descriptor.iSerialNumber);
      seen.push_back(serial);
      if (!options_.serial.empty() && serial != options_.serial) {
        libusb_close(handle);
        continue;
      }
      handle_ = handle;
      identity_.vendor = ReadString(handle, descriptor.iManufacturer);
      identity_.model = ReadString(handle, descriptor.iProduct);
      identity_.serial = serial;
      identity_.firmware = std::to_string(descriptor.bcdDevice >> 8) + "." + std::to_string(descriptor.bcdDevice & 0xFF);
    }
    libusb_free_device_list(list, 1);
    if (handle_ == nullptr) {
      if (!seen.empty()) {
        std::sort(seen.begin(), seen.end());
        std::string serials;
        for (const std::string& s : seen) serials += (serials.empty() ? "" : ", ") + s;
        return Error(StatusCode::kNotFound, "no wheel with serial '" + options_.serial + "' (connected: " + serials + ")");
      }
      return failure;
    }
    if (const int rc = libusb_claim_interface(handle_, 0); rc != 0) return UsbError(rc, "cannot claim interface 0");
    return identity_;
  }

  Status Send(uint8_t request, uint16_t value, const std::string& what) {
    const int rc = libusb_control_transfer(handle_, proto::kRequestTypeOut, request, value, 0, nullptr, 0,
                                           static_cast<unsigned>(options_.request_timeout_ms));
    return rc < 0 ? UsbError(rc, what) : Status::Ok();
  }

  Result<WheelStatus> ReadStatus() {
    std::array<unsigned char, 4> data{};
    const int rc = libusb_control_transfer(handle_, proto::kRequestTypeIn, proto::kGetStatus, 0, 0, data.data(), data.size(),
                                           static_cast<unsigned>(options_.request_timeout_ms));
    if (rc < 0) return UsbError(rc, "reading the status");
    if (rc != 4) return Error(StatusCode::kDataLoss, "status reply of " + std::to_string(rc) + " bytes, expected 4");
    return WheelStatus{data[0], data[1] != 0, data[2], data[3]};
  }

  void Release() {
    if (handle_ != nullptr) {
      libusb_release_interface(handle_, 0);
      libusb_close(handle_);
      handle_ = nullptr;
    }
    if (context_ != nullptr) {
      libusb_exit(context_);
      context_ = nullptr;
    }
  }

  UsbWheelOptions options_;
  libusb_context* context_ = nullptr;
  libusb_device_handle* handle_ = nullptr;
  DeviceIdentity identity_;
};

}  // namespace

void RegisterUsbBackend(BackendRegistry& registry) {
  registry.Register<FilterWheel>("usb", [](const DeviceConfig& config) -> Result<std::unique_ptr<FilterWheel>> {
    UsbWheelOptions options;
    config.node.Optional("serial", &options.serial);
    config.node.Optional("vendor_id", &options.vendor_id);
    config.node.Optional("product_id", &options.product_id);
    config.node.Optional("request_timeout_ms", &options.request_timeout_ms);
    return std::unique_ptr<FilterWheel>(std::make_unique<UsbFilterWheel>(config.name, options));
  });
}

}  // namespace loom::hal
