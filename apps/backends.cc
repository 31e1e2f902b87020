#include "apps/backends.h"

#include "hal/aravis/aravis_backend.h"
#include "hal/display/display_projector.h"
#include "hal/modbus/modbus_backends.h"
#include "hal/recording/recording_projector.h"
#include "hal/usb/usb_backend.h"

namespace loom::apps {

hal::BackendRegistry AllBackends() {
  hal::BackendRegistry registry;
  hal::RegisterAravisBackend(registry);
  hal::RegisterModbusBackends(registry);
  hal::RegisterUsbBackend(registry);
  hal::RegisterDisplayBackend(registry);
  hal::RegisterRecordingBackend(registry);
  return registry;
}

}  // namespace loom::apps
