#include "apps/backends.h"

#include "apps/config_paths.h"
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

Result<LoadedRig> LoadRig(const std::string& rig, const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Load(ResolveRigPath(rig)));
  return acquisition::LoadRig(file, AllBackends(), object);
}

}  // namespace loom::apps
