#include "apps/rig_loader.h"

#include <algorithm>

#include "apps/backends.h"
#include "core/rig_model.h"

namespace loom::apps {

namespace {

// A simulated rig's `as_built:` — how the simulated hardware differs from its `geometry:`, the
// nominal description loom is given — so that calibration has something to find:
//   as_built:
//     cameras: [{name: cam1, move_mm: [1, -2, 0.5], rotate_deg: [0.3, 0, -0.2], sensitivity_scale: 0.9, vignetting: 0.2}]
//     leds: [{index: 3, intensity_scale: 0.85, move_mm: [5, -3, 2]}]
//     filter_wheels: [{name: wheel0, slot: 2, shift_nm: 8}]
//     projector: {move_mm: [2, 0, -1], rotate_deg: [0.5, 0, 0], focal_scale: 1.03, shift_cx_px: 4}
//     linear_light: {turn_deg: 1.5}
// move_mm shifts a camera's, the projector's or an LED's centre (rig frame); rotate_deg turns a
// camera or the projector about its own x, y, z; the scales multiply the nominal sensitivity and
// intensity (focal_scale the projector's focal length); shift_cx_px moves the projector's
// principal point along its columns; shift_nm moves a filter's band; turn_deg turns the linear light's arm about its
// sweep axis at every carriage position (an offset of its start and end angles).

// A device's pose moved by `move_mm` (its centre, rig frame) and turned by `rotate_deg` (about
// its own x, y, z).
Rigid3d Moved(const ConfigNode& node, const Rigid3d& from_rig) {
  Eigen::Vector3d move = Eigen::Vector3d::Zero(), rotate_deg = Eigen::Vector3d::Zero();
  node.Optional("move_mm", &move);
  node.Optional("rotate_deg", &rotate_deg);
  const Eigen::Matrix3d turn = (Eigen::AngleAxisd(DegToRad(rotate_deg.z()), Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(DegToRad(rotate_deg.y()), Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(DegToRad(rotate_deg.x()), Eigen::Vector3d::UnitX())).toRotationMatrix();
  const Eigen::Vector3d centre = from_rig.inverse().translation() + move;
  const Eigen::Matrix3d rotation = turn * from_rig.rotation();
  return MakeRigid(rotation, -rotation * centre);
}

void MoveCamera(const ConfigNode& node, CameraModel* camera) {
  camera->cam_from_rig = Moved(node, camera->cam_from_rig);
  double sensitivity_scale = 1;
  node.Optional("sensitivity_scale", &sensitivity_scale);
  camera->sensor.sensitivity *= sensitivity_scale;
  node.Optional("vignetting", &camera->sensor.vignetting);
}

template <typename Device>
Device* FindByName(std::vector<Device>& devices, const ConfigNode& node, const char* what) {
  std::string name;
  node.Required("name", &name);
  const auto found = std::find_if(devices.begin(), devices.end(), [&](const Device& d) { return d.name == name; });
  if (found != devices.end()) return &*found;
  node.AddError("name", std::string("no ") + what + " '" + name + "' in the geometry");
  return nullptr;
}

RigModel AsBuilt(const ConfigNode& root, RigModel model) {
  const std::optional<ConfigNode> as_built = root.OptionalChild("as_built");
  if (!as_built) return model;
  for (const ConfigNode& node : as_built->OptionalSequence("cameras")) {
    if (CameraModel* camera = FindByName(model.cameras, node, "camera")) MoveCamera(node, camera);
  }
  for (const ConfigNode& node : as_built->OptionalSequence("leds")) {
    int index = -1;
    double scale = 1;
    Eigen::Vector3d move = Eigen::Vector3d::Zero();
    node.Required("index", &index);
    node.Optional("intensity_scale", &scale);
    node.Optional("move_mm", &move);
    if (index < 0 || index >= static_cast<int>(model.leds.size())) {
      node.AddError("index", "no LED " + std::to_string(index) + " in the geometry");
      continue;
    }
    model.leds[index].intensity *= scale;
    model.leds[index].position_mm += move;
  }
  for (const ConfigNode& node : as_built->OptionalSequence("filter_wheels")) {
    FilterWheelModel* wheel = FindByName(model.filter_wheels, node, "filter wheel");
    int slot = -1;
    double shift_nm = 0;
    node.Required("slot", &slot);
    node.Required("shift_nm", &shift_nm);
    if (wheel == nullptr) continue;
    if (slot < 0 || slot >= static_cast<int>(wheel->filters.size())) {
      node.AddError("slot", "no slot " + std::to_string(slot) + " on " + wheel->name);
      continue;
    }
    wheel->filters[slot].center_nm += shift_nm;
  }
  if (const std::optional<ConfigNode> node = as_built->OptionalChild("linear_light")) {
    double turn_deg = 0;
    node->Required("turn_deg", &turn_deg);
    if (model.linear_light) {
      model.linear_light->start_deg += turn_deg;
      model.linear_light->end_deg += turn_deg;
    } else {
      node->AddError("turn_deg", "the geometry has no linear light");
    }
  }
  if (const std::optional<ConfigNode> node = as_built->OptionalChild("projector")) {
    if (model.projector) {
      model.projector->proj_from_rig = Moved(*node, model.projector->proj_from_rig);
      double focal_scale = 1, shift_cx_px = 0;
      node->Optional("focal_scale", &focal_scale);
      node->Optional("shift_cx_px", &shift_cx_px);
      if (!(focal_scale > 0)) node->AddError("focal_scale", "must be > 0");
      model.projector->K(0, 0) *= focal_scale;
      model.projector->K(1, 1) *= focal_scale;
      model.projector->K(0, 2) += shift_cx_px;
    } else {
      node->AddError("move_mm", "the geometry has no projector");
    }
  }
  return model;
}

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
    sample.target = model.calibration_target;
    sample.chart = model.colour_chart;
    sample.white = model.white_reference;
    if (model.light_probe) sample.probe = *model.light_probe;
    loaded.sample = sample;
    int seed = 0;
    root.Optional("seed", &seed);
    Result<sim::Material> material = sim::MakeSample(sample);
    if (!material.ok()) return material.status().WithContext(source);
    loaded.world = std::make_shared<hal::SimWorld>(std::make_shared<sim::Scene>(AsBuilt(root, model), std::move(*material)),
                                                   static_cast<uint64_t>(seed));
    hal::RegisterSimBackends(registry, loaded.world);
  }
  Result<std::unique_ptr<hal::Rig>> rig = hal::Rig::Create(root.Child("devices"), registry, name);
  if (!rig.ok()) return rig.status().WithContext(source);
  root.Ignore("recalibration");  // loom calibrate check's thresholds
  LOOM_RETURN_IF_ERROR(doc.Finish());
  loaded.rig = std::move(*rig);
  return loaded;
}

}  // namespace

Status PlaceSimObject(const LoadedRig& loaded, const std::string& object) {
  if (!loaded.world) return FailedPreconditionError("rig '" + loaded.rig->name() + "'", "is not simulated");
  if (loaded.world->object() == object) return Status::Ok();  // e.g. a scan's first step: the sample is there
  sim::SampleSpec spec = loaded.sample;
  if (object == "target") {
    spec.kind = "target";
  } else if (object == "white tile") {
    spec.kind = "white-tile";
  } else if (object == "white tile on its spacer") {
    spec.kind = "white-tile-on-spacer";
  } else if (object == "colour chart") {
    spec.kind = "colour-chart";
  } else if (object == "chrome sphere") {
    spec.kind = "chrome-sphere";
  } else if (object != "sample") {
    return InvalidArgumentError("object '" + object + "'", "a simulated rig has: sample, target, white tile, white tile on its spacer, colour chart, chrome sphere");
  }
  LOOM_ASSIGN_OR_RETURN(sim::Material material, sim::MakeSample(spec));
  const std::shared_ptr<const sim::Scene> current = loaded.world->scene();
  loaded.world->set_scene(std::make_shared<sim::Scene>(current->rig(), std::move(material)), object);
  return Status::Ok();
}

Result<LoadedRig> LoadRig(const std::filesystem::path& path, const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadFile(path, kRigSchemaVersion));
  return LoadRigDocument(doc, path.string(), object);
}

Result<LoadedRig> LoadRigFromText(const std::string& text, const std::string& source, const std::string& object) {
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadString(text, source, kRigSchemaVersion));
  return LoadRigDocument(doc, source, object);
}

namespace {

// A file by path, or by NAME in configs/<folder>/NAME.yaml, here or in loom's source tree.
std::filesystem::path ResolveConfigPath(const std::string& folder, const std::string& name) {
  namespace fs = std::filesystem;
  if (fs::exists(name)) return name;
  const fs::path local = fs::path("configs") / folder / (name + ".yaml");
  if (fs::exists(local)) return local;
  return fs::path(LOOM_CONFIGS_DIR) / folder / (name + ".yaml");
}

}  // namespace

std::filesystem::path ResolvePresetPath(const std::string& preset) { return ResolveConfigPath("plans", preset); }

std::filesystem::path ResolveRigPath(const std::string& rig) { return ResolveConfigPath("rig", rig); }

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
  for (const char* other : {"devices", "sample", "seed", "as_built", "recalibration"}) root.Ignore(other);
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
