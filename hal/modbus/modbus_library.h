#pragma once
// The libmodbus library this build loaded.
#include "core/version.h"

namespace loom::hal {
LinkedLibrary ModbusLibrary();
}
