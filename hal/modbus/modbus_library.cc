#include "hal/modbus/modbus_library.h"

#include <modbus.h>

namespace loom::hal {

LinkedLibrary ModbusLibrary() {
  return {"libmodbus", std::to_string(libmodbus_version_major) + "." + std::to_string(libmodbus_version_minor) + "." +
                           std::to_string(libmodbus_version_micro)};
}

}  // namespace loom::hal
