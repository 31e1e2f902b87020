#include "hal/usb/emulated_filter_wheel.h"

#include <linux/ioctl.h>
#include <linux/usbdevice_fs.h>
#include <sys/ioctl.h>

#include <cerrno>
#include <cstring>

#include "hal/usb/filter_wheel_protocol.h"

namespace loom::hal::testing {
namespace {

namespace proto = usb_wheel;

constexpr uint8_t kStandardIn = 0x80;
constexpr uint8_t kGetDescriptor = 0x06;
constexpr uint8_t kStringDescriptor = 0x03;

// Device (18 bytes), configuration (9) and interface (9) descriptors, as sysfs holds them.
std::string DescriptorsHex() {
  const uint8_t bytes[] = {// device: USB 2.0, vendor class, EP0 64 bytes, VID, PID, bcdDevice 1.00, strings 1/2/3
                           0x12, 0x01, 0x00, 0x02, 0xFF, 0x00, 0x00, 0x40, proto::kDefaultVendorId & 0xFF,
                           proto::kDefaultVendorId >> 8, proto::kDefaultProductId & 0xFF, proto::kDefaultProductId >> 8, 0x00,
                           0x01, proto::kManufacturerString, proto::kProductString, proto::kSerialString, 0x01,
                           // configuration 1: one interface, bus-powered, 100 mA
                           0x09, 0x02, 0x12, 0x00, 0x01, 0x01, 0x00, 0x80, 0x32,
                           // interface 0: vendor class, no endpoints besides EP0
                           0x09, 0x04, 0x00, 0x00, 0x00, 0xFF, 0x00, 0x00, 0x00};
  std::string hex;
  char byte[3];
  for (uint8_t b : bytes) {
    std::snprintf(byte, sizeof(byte), "%02x", b);
    hex += byte;
  }
  return hex;
}

std::vector<uint8_t> StringDescriptor(const std::string& text) {
  std::vector<uint8_t> out = {static_cast<uint8_t>(2 + 2 * text.size()), kStringDescriptor};
  for (char c : text) {
    out.push_back(static_cast<uint8_t>(c));
    out.push_back(0);
  }
  return out;
}

}  // namespace

EmulatedFilterWheel::EmulatedFilterWheel(UMockdevTestbed* testbed, int device_number, std::string serial, int slots,
                                         int ms_per_slot)
    : serial_(std::move(serial)), slots_(slots), per_slot_(ms_per_slot) {
  char number[4];
  std::snprintf(number, sizeof(number), "%03d", device_number);
  const std::string node = std::string("/dev/bus/usb/001/") + number;
  handler_ = umockdev_ioctl_base_new();
  g_signal_connect(handler_, "handle-ioctl", G_CALLBACK(&EmulatedFilterWheel::OnIoctl), this);
  // The ioctl handler first: the device must answer as soon as it appears.
  umockdev_testbed_attach_ioctl(testbed, node.c_str(), handler_, nullptr);
  const std::string description = "P: /devices/usb1/1-" + std::to_string(device_number) +
                                  "\n"
                                  "N: bus/usb/001/" +
                                  number +
                                  "\n"
                                  "E: SUBSYSTEM=usb\nE: DEVTYPE=usb_device\nE: DEVNAME=" +
                                  node +
                                  "\n"
                                  "E: BUSNUM=001\nE: DEVNUM=" +
                                  number +
                                  "\n"
                                  "A: busnum=1\\n\nA: devnum=" +
                                  std::to_string(device_number) +
                                  "\\n\n"
                                  "A: speed=12\\n\nA: bConfigurationValue=1\\n\n"
                                  "A: serial=" +
                                  serial_ +
                                  "\\n\n"
                                  "H: descriptors=" +
                                  DescriptorsHex() + "\n";
  umockdev_testbed_add_from_string(testbed, description.c_str(), nullptr);
}

EmulatedFilterWheel::~EmulatedFilterWheel() {
  std::lock_guard lock(mutex_);
  for (PendingUrb& pending : completed_) umockdev_ioctl_data_unref(pending.urb);
  g_clear_object(&handler_);
}

void EmulatedFilterWheel::JamNextMove() {
  std::lock_guard lock(mutex_);
  jam_next_ = true;
}

void EmulatedFilterWheel::Unplug() {
  std::lock_guard lock(mutex_);
  unplugged_ = true;
}

int EmulatedFilterWheel::requests() const {
  std::lock_guard lock(mutex_);
  return requests_;
}

gboolean EmulatedFilterWheel::OnIoctl(UMockdevIoctlBase*, UMockdevIoctlClient* client, gpointer self) {
  return static_cast<EmulatedFilterWheel*>(self)->HandleIoctl(client);
}

void EmulatedFilterWheel::AdvanceMotion() {
  if (moving_ && std::chrono::steady_clock::now() >= move_end_) {
    moving_ = false;
    if (jam_next_) {
      jam_next_ = false;
      error_ = proto::kErrorJammed;  // stopped between slots
    } else {
      slot_ = target_;
    }
  }
}

bool EmulatedFilterWheel::Answer(const uint8_t* setup, std::vector<uint8_t>* in_data) {
  const uint8_t type = setup[0];
  const uint8_t request = setup[1];
  const uint16_t value = static_cast<uint16_t>(setup[2] | (setup[3] << 8));
  ++requests_;
  AdvanceMotion();
  if (type == kStandardIn && request == kGetDescriptor && (value >> 8) == kStringDescriptor) {
    switch (value & 0xFF) {
      case 0:
        *in_data = {4, kStringDescriptor, 0x09, 0x04};
        return true;  // English (US)
      case proto::kManufacturerString:
        *in_data = StringDescriptor("loom");
        return true;
      case proto::kProductString:
        *in_data = StringDescriptor("loom filter wheel");
        return true;
      case proto::kSerialString:
        *in_data = StringDescriptor(serial_);
        return true;
      default:
        return false;
    }
  }
  if (type == proto::kRequestTypeIn && request == proto::kGetStatus) {
    *in_data = {static_cast<uint8_t>(moving_ ? proto::kSlotMoving : slot_), static_cast<uint8_t>(moving_),
                static_cast<uint8_t>(error_), static_cast<uint8_t>(slots_)};
    return true;
  }
  if (type == proto::kRequestTypeOut && (request == proto::kMove || request == proto::kHome)) {
    const int target = request == proto::kHome ? 0 : value;
    if (target >= slots_ || error_ != proto::kErrorNone) return false;  // STALL
    target_ = target;
    moving_ = true;
    move_end_ = std::chrono::steady_clock::now() + per_slot_ * std::max(1, std::abs(target - slot_));
    return true;
  }
  if (type == proto::kRequestTypeOut && request == proto::kClearError) {
    error_ = proto::kErrorNone;
    return true;
  }
  return false;
}

bool EmulatedFilterWheel::HandleIoctl(UMockdevIoctlClient* client) {
  const gulong request = umockdev_ioctl_client_get_request(client);
  UMockdevIoctlData* arg = umockdev_ioctl_client_get_arg(client);
  std::lock_guard lock(mutex_);
  const bool reap = request == USBDEVFS_REAPURB || request == USBDEVFS_REAPURBNDELAY;
  if (unplugged_) {
    // As usbfs does after a disconnect (USBDEVFS_CAP_REAP_AFTER_DISCONNECT): URBs in flight
    // are still reaped, failed with ENODEV; then every call fails. Refusing to reap them left
    // libusb waiting forever on a transfer submitted just before the unplug.
    for (PendingUrb& pending : completed_) pending.status = -ENODEV, pending.in_data.clear();
    if (!reap || completed_.empty()) {
      umockdev_ioctl_client_complete(client, -1, ENODEV);
      return true;
    }
  }
  switch (request) {
    case USBDEVFS_GET_CAPABILITIES: {
      UMockdevIoctlData* data = umockdev_ioctl_data_resolve(arg, 0, sizeof(guint32), nullptr);
      *reinterpret_cast<guint32*>(data->data) = USBDEVFS_CAP_REAP_AFTER_DISCONNECT | USBDEVFS_CAP_NO_PACKET_SIZE_LIM;
      umockdev_ioctl_data_unref(data);
      umockdev_ioctl_client_complete(client, 0, 0);
      return true;
    }
    case USBDEVFS_CLAIMINTERFACE:
    case USBDEVFS_RELEASEINTERFACE:
    case USBDEVFS_CLEAR_HALT:
    case USBDEVFS_RESET:
      umockdev_ioctl_client_complete(client, 0, 0);
      return true;
    case USBDEVFS_SUBMITURB: {
      UMockdevIoctlData* urb_data = umockdev_ioctl_data_resolve(arg, 0, sizeof(usbdevfs_urb), nullptr);
      auto* urb = reinterpret_cast<usbdevfs_urb*>(urb_data->data);
      if (urb->type != USBDEVFS_URB_TYPE_CONTROL || urb->buffer_length < 8) {
        umockdev_ioctl_data_unref(urb_data);
        umockdev_ioctl_client_complete(client, -1, EINVAL);
        return true;
      }
      UMockdevIoctlData* buffer =
          umockdev_ioctl_data_resolve(urb_data, G_STRUCT_OFFSET(usbdevfs_urb, buffer), urb->buffer_length, nullptr);
      PendingUrb pending{urb_data, {}, 0};
      if (!Answer(buffer->data, &pending.in_data)) pending.status = -EPIPE;
      umockdev_ioctl_data_unref(buffer);
      completed_.push_back(std::move(pending));
      umockdev_ioctl_client_complete(client, 0, 0);
      return true;
    }
    case USBDEVFS_REAPURB:
    case USBDEVFS_REAPURBNDELAY: {
      if (completed_.empty()) {
        umockdev_ioctl_client_complete(client, -1, EAGAIN);
        return true;
      }
      PendingUrb pending = std::move(completed_.front());
      completed_.pop_front();
      auto* urb = reinterpret_cast<usbdevfs_urb*>(pending.urb->data);
      const int room = urb->buffer_length - 8;
      const int length = std::min<int>(room, static_cast<int>(pending.in_data.size()));
      // Same address space (umockdev-wrapper preloads into this process): write the IN data
      // straight behind the setup packet, as the kernel would.
      if (length > 0) std::memcpy(static_cast<uint8_t*>(urb->buffer) + 8, pending.in_data.data(), length);
      urb->actual_length = pending.status == 0 ? length : 0;
      urb->status = pending.status;
      UMockdevIoctlData* pointer = umockdev_ioctl_data_resolve(arg, 0, sizeof(gpointer), nullptr);
      umockdev_ioctl_data_set_ptr(pointer, 0, pending.urb);
      umockdev_ioctl_client_complete(client, 0, 0);
      umockdev_ioctl_data_unref(pointer);
      umockdev_ioctl_data_unref(pending.urb);
      return true;
    }
    case USBDEVFS_DISCARDURB:
      umockdev_ioctl_client_complete(client, -1, EINVAL);
      return true;
    default:
      return false;
  }
}

}  // namespace loom::hal::testing
