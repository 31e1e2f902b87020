#include "apps/rig_loader.h"

#include "apps/backends.h"

namespace loom::apps {

namespace {

Result<LoadedRig> LoadRigFile(const RigFile& file, const std::string& object) {
  hal::BackendRegistry registry = AllBackends();
  LoadedRig loaded;
  if (file.Has("geometry")) {
    LOOM_ASSIGN_OR_RETURN(loaded.model, file.Model());
    LOOM_ASSIGN_OR_RETURN(loaded.sim, hal::MakeSimRig(file, *loaded.model, object));
    hal::RegisterSimBackends(registry, loaded.sim->world);
  }
  loaded.light_drift = scan::ReadLightDriftSettings(file);
  loaded.device_faults = acquisition::ReadDeviceFaultPolicy(file);
  LOOM_ASSIGN_OR_RETURN(loaded.rig, hal::Rig::Load(file, registry));
  return loaded;
}

}  // namespace

Result<LoadedRig> LoadRig(const std::string& rig, const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Load(ResolveRigPath(rig)));
  return LoadRigFile(file, object);
}

Result<LoadedRig> LoadRigFromText(const std::string& text, const std::string& source, const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Parse(text, source));
  return LoadRigFile(file, object);
}

}  // namespace loom::apps
