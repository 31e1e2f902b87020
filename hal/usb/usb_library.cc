#include "hal/usb/usb_library.h"

#include <libusb.h>

namespace loom::hal {

LinkedLibrary UsbLibrary() {
  const libusb_version* v = libusb_get_version();
  return {"libusb", std::to_string(v->major) + "." + std::to_string(v->minor) + "." + std::to_string(v->micro)};
}

}  // namespace loom::hal
