#include "sim/rig_scene.h"

#include <algorithm>
#include <charconv>

namespace loom::sim {
namespace {

// A device's pose moved by `move_mm` (its centre, rig frame) and turned by `rotate_deg` (about
// its own x, y, z).
Rigid3d Moved(const ConfigNode& node, const Rigid3d& from_rig) {
  Eigen::Vector3d move = Eigen::Vector3d::Zero(), rotate_deg = Eigen::Vector3d::Zero();
  node.Optional("move_mm", &move);
  node.Optional("rotate_deg", &rotate_deg);
  const Eigen::Matrix3d turn = (Eigen::AngleAxisd(DegToRad(rotate_deg.z()), Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(DegToRad(rotate_deg.y()), Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(DegToRad(rotate_deg.x()), Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
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
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
  double quartic = 0;
  node.Optional("vignetting_centre_px", &centre_px);
  node.Optional("vignetting_quartic", &quartic);
  if (!centre_px.allFinite() || centre_px.cwiseAbs().maxCoeff() > 0.25 * std::max(camera->width, camera->height)) {
    node.AddError("vignetting_centre_px", "must be finite and within a quarter of the sensor");
  } else if (!(quartic >= 0 && quartic < 0.5)) {
    node.AddError("vignetting_quartic", "must be in [0, 0.5)");
  } else if (quartic > 0 || centre_px != Eigen::Vector2d::Zero()) {
    camera->sensor.flat_field = NonQuadraticVignetting(*camera, centre_px, quartic);
  }
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

}  // namespace

std::shared_ptr<const Image> NonQuadraticVignetting(const CameraModel& camera, const Eigen::Vector2d& centre_px, double quartic) {
  auto flat = std::make_shared<Image>(camera.width, camera.height, std::vector<std::string>{"flat"});
  SensorModel unit;
  unit.vignetting = 1;
  for (int y = 0; y < camera.height; ++y) {
    for (int x = 0; x < camera.width; ++x) {
      const double q = 1 - unit.QuadraticResponse(x - centre_px.x(), y - centre_px.y(), camera.width, camera.height);
      const double response = 1 - camera.sensor.vignetting * q - quartic * q * q;
      flat->at(0, y, x) = static_cast<float>(response / camera.sensor.QuadraticResponse(x, y, camera.width, camera.height));
    }
  }
  return flat;
}

RigModel AsBuilt(const RigFile& file, RigModel model) {
  const std::optional<ConfigNode> as_built = file.Section("as_built");
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
    std::vector<double> profile;
    node->Optional("turn_deg", &turn_deg);
    node->Optional("profile", &profile);
    if (const std::string problem = LinearLightModel::ProfileProblem(profile); !problem.empty())
      node->AddError("profile", problem);
    if (model.linear_light) {
      model.linear_light->start_deg += turn_deg;
      model.linear_light->end_deg += turn_deg;
      if (!profile.empty()) model.linear_light->profile = profile;
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

Result<RigScene> MakeRigScene(const RigFile& file, const RigModel& model, const std::string& object) {
  SampleSpec sample;
  if (std::optional<ConfigNode> node = file.Section("sample")) sample = ReadSampleSpec(*node);
  if (!object.empty()) {
    const size_t colon = object.find(':');
    sample.kind = object.substr(0, colon);
    if (colon != std::string::npos) {
      const std::string_view seed = std::string_view(object).substr(colon + 1);
      const auto [end, error] = std::from_chars(seed.data(), seed.data() + seed.size(), sample.seed);
      if (error != std::errc() || end != seed.data() + seed.size()) {
        return InvalidArgumentError("object '" + object + "'", "expected KIND or KIND:SEED, SEED a whole number >= 0");
      }
    }
  }
  sample.target = model.calibration_target;
  sample.chart = model.colour_chart;
  sample.white = model.white_reference;
  if (model.light_probe) sample.probe = *model.light_probe;
  Result<Material> material = MakeSample(sample);
  if (!material.ok()) return material.status().WithContext(file.source());
  return RigScene{std::make_shared<Scene>(AsBuilt(file, model), std::move(*material)), sample};
}

}  // namespace loom::sim
