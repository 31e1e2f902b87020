#include "apps/rig_loader.h"

#include "apps/backends.h"
#include "core/rig_model.h"
#include "sim/sample.h"

namespace loom::apps {

namespace {

Result<LoadedRig> LoadRigDocument(const ConfigDocument& doc, const std::string& source, const std::string& object) {
  const ConfigNode root = doc.root();
  std::string name;
  root.Required("name", &name);
  hal::BackendRegistry registry = AllBackends();
  LoadedRig loaded;
  if (std::optional<ConfigNode> geometry = root.OptionalChild("geometry")) {
    RigModel model = ReadRigModel(*geometry);
    model.name = name;
    loaded.model = model;
    sim::SampleSpec sample;
    if (std::optional<ConfigNode> sample_node = root.OptionalChild("sample")) sample = sim::ReadSampleSpec(*sample_node);
    if (!object.empty()) {
      const size_t colon = object.find(':');
      sample.kind = object.substr(0, colon);
      try {
        if (colon != std::string::npos) sample.seed = std::stoull(object.substr(colon + 1));
      } catch (const std::exception&) {
        return InvalidArgumentError("object '" + object + "'", "expected KIND or fabric:SEED");
      }
    }
    int seed = 0;
    root.Optional("seed", &seed);
    Result<sim::Material> material = sim::MakeSample(sample);
    if (!material.ok()) return material.status().WithContext(source);
    loaded.world = std::make_shared<hal::SimWorld>(std::make_shared<sim::Scene>(std::move(model), std::move(*material)),
                                                   static_cast<uint64_t>(seed));
    hal::RegisterSimBackends(registry, loaded.world);
  }
  Result<std::unique_ptr<hal::Rig>> rig = hal::Rig::Create(root.Child("devices"), registry, name);
  if (!rig.ok()) return rig.status().WithContext(source);
  LOOM_RETURN_IF_ERROR(doc.Finish());
  loaded.rig = std::move(*rig);
  return loaded;
}

}  // namespace

Result<LoadedRig> LoadRig(const std::filesystem::path& path, const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadFile(path, kRigSchemaVersion));
  return LoadRigDocument(doc, path.string(), object);
}

Result<LoadedRig> LoadRigFromText(const std::string& text, const std::string& source, const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadString(text, source, kRigSchemaVersion));
  return LoadRigDocument(doc, source, object);
}

std::filesystem::path ResolvePresetPath(const std::string& preset) {
  namespace fs = std::filesystem;
  if (fs::exists(preset)) return preset;
  const fs::path local = fs::path("configs/plans") / (preset + ".yaml");
  if (fs::exists(local)) return local;
  return fs::path(LOOM_CONFIGS_DIR) / "plans" / (preset + ".yaml");
}

namespace {

Result<RigModel> RigModelOf(const ConfigDocument& doc, const std::string& source) {
  const ConfigNode root = doc.root();
  std::string name;
  root.Required("name", &name);
  if (!root.Has("geometry")) {
    return InvalidArgumentError(source, "has no 'geometry:' section: planning and reconstruction need the rig's description");
  }
  RigModel model = ReadRigModel(root.Child("geometry"));
  model.name = name;
  for (const char* other : {"devices", "sample", "seed"}) root.Ignore(other);
  LOOM_RETURN_IF_ERROR(doc.Finish());
  return model;
}

}  // namespace

Result<RigModel> LoadRigModel(const std::filesystem::path& path) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadFile(path, kRigSchemaVersion));
  return RigModelOf(doc, path.string());
}

Result<RigModel> LoadRigModelFromText(const std::string& text, const std::string& source) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadString(text, source, kRigSchemaVersion));
  return RigModelOf(doc, source);
}

}  // namespace loom::apps
