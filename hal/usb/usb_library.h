#pragma once
// The libusb-1.0 library this build loaded.
#include "core/version.h"

namespace loom::hal {
LinkedLibrary UsbLibrary();
}
