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

namespace {

// A file by path, or by NAME in configs/<folder>/NAME.yaml, here or in loom's source tree. A
// directory of that name (a model's, a scan's) is not a config file.
std::filesystem::path ResolveConfigPath(const std::string& folder, const std::string& name) {
  namespace fs = std::filesystem;
  if (fs::exists(name) && !fs::is_directory(name)) return name;
  const fs::path local = fs::path("configs") / folder / (name + ".yaml");
  if (fs::exists(local)) return local;
  return fs::path(LOOM_CONFIGS_DIR) / folder / (name + ".yaml");
}

}  // namespace

std::filesystem::path ResolvePresetPath(const std::string& preset) { return ResolveConfigPath("plans", preset); }

std::filesystem::path ResolveRigPath(const std::string& rig) {
  const std::filesystem::path found = ResolveConfigPath("rig", rig);
  return std::filesystem::exists(found) ? found : std::filesystem::path(rig);
}

}  // namespace loom::apps
