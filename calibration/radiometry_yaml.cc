#include "calibration/radiometry_yaml.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "calibration/internal/provenance.h"
#include "core/config.h"
#include "core/exr_io.h"
#include "core/file_io.h"
#include "core/output_directory.h"

namespace loom::calibration {
namespace {

namespace fs = std::filesystem;

constexpr int kSchemaVersion = 1;
constexpr char kCameraModel[] =
    "radiance = DN/us above black * electrons_per_dn / (gain * sensitivity * 1e-6 * (1 - vignetting * (r / r_corner)^2))";
constexpr char kLedModel[] =
    "radiant intensity at 1000 mA along the axis * cos^falloff_exponent(angle to the axis), radiance units * mm^2";
constexpr char kLinearLightModel[] = "radiant intensity per mm of strip along its normal at full power, radiance units * mm";
constexpr char kWheelModel[] =
    "a camera records weights . (R, G, B) of a linear-sRGB albedo through the slot; the open slot records 1";

// A camera's per-pixel flat field: CAMERA-flat.exr beside CAMERA.yaml, its channel "flat" the
// response over the quadratic model (core/rig_model.h's SensorModel::flat_field).
constexpr char kFlatFieldSuffix[] = "-flat.exr";

fs::path Folder(const fs::path& directory) { return directory / "radiometry"; }

void BeginFile(YAML::Emitter& out, const std::string& device, const std::string& name, const char* model, const Radiometry& r) {
  out.SetDoublePrecision(17);  // doubles round-trip exactly
  out << YAML::BeginMap;
  out << YAML::Key << "schema_version" << YAML::Value << kSchemaVersion;
  out << YAML::Key << "device" << YAML::Value << device;
  out << YAML::Key << "name" << YAML::Value << name;
  out << YAML::Key << "model" << YAML::Value << model;
  out << YAML::Key << "reference_camera" << YAML::Value << r.reference_camera;
  out << YAML::Key << "white_albedo" << YAML::Value << r.white_albedo;
}

Status EndFile(YAML::Emitter& out, const std::string& from, const fs::path& path) {
  internal::EmitSource(out, from);
  out << YAML::EndMap;
  return WriteFileAtomically(path, std::string(out.c_str()) + "\n");
}

Status WriteCamera(const fs::path& folder, const CameraRadiometry& c, const Radiometry& r, const std::string& from) {
  YAML::Emitter out;
  BeginFile(out, "camera", c.name, kCameraModel, r);
  out << YAML::Key << "sensitivity" << YAML::Value << c.sensitivity;
  out << YAML::Key << "sensitivity_change" << YAML::Value << c.sensitivity_change;
  out << YAML::Key << "vignetting" << YAML::Value << c.vignetting;
  out << YAML::Key << "black_dn" << YAML::Value << c.black_dn;
  out << YAML::Key << "read_noise_dn" << YAML::Value << c.read_noise_dn;
  if (c.flat_field) {
    const std::string flat_file = c.name + kFlatFieldSuffix;
    LOOM_RETURN_IF_ERROR(WriteExr(folder / flat_file, *c.flat_field));
    out << YAML::Key << "flat_field" << YAML::Value << flat_file;
  }
  out << YAML::Key << "quality" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "flat_field_residual" << YAML::Value << c.flat_field_residual;
  out << YAML::Key << "flat_field_max" << YAML::Value << c.flat_field_max;
  out << YAML::Key << "tile_pixels" << YAML::Value << c.tile_pixels;
  out << YAML::Key << "linearity_deviation" << YAML::Value;
  if (std::isnan(c.linearity_deviation)) {
    out << "not measured (no two exposures read the tile well)";
  } else {
    out << c.linearity_deviation;
  }
  out << YAML::Key << "linearity_max_dn" << YAML::Value << c.linearity_max_dn << YAML::EndMap;
  return EndFile(out, from, folder / (c.name + ".yaml"));
}

Status WriteLights(const fs::path& folder, const Radiometry& r, const std::string& from) {
  YAML::Emitter leds;
  BeginFile(leds, "leds", "leds", kLedModel, r);
  std::ostringstream falloff;
  falloff << "nominal (the rig YAML's): not observable, the white reference subtends " << r.tile_subtends_deg
          << " deg from an LED";
  leds << YAML::Key << "falloff" << YAML::Value << falloff.str();
  leds << YAML::Key << "tile_subtends_deg" << YAML::Value << r.tile_subtends_deg;
  leds << YAML::Key << "leds" << YAML::Value << YAML::BeginSeq;
  for (const LightRadiometry& light : r.lights) {
    if (light.led < 0) continue;
    leds << YAML::Flow << YAML::BeginMap << YAML::Key << "index" << YAML::Value << light.led << YAML::Key << "intensity"
         << YAML::Value << light.intensity << YAML::Key << "change" << YAML::Value << light.change << YAML::Key << "camera_spread"
         << YAML::Value << light.camera_spread << YAML::EndMap;
  }
  leds << YAML::EndSeq;
  LOOM_RETURN_IF_ERROR(EndFile(leds, from, folder / "leds.yaml"));
  for (const LightRadiometry& light : r.lights) {
    if (light.led >= 0) continue;
    YAML::Emitter strip;
    BeginFile(strip, "linear_light", "linear_light", kLinearLightModel, r);
    strip << YAML::Key << "intensity_per_mm" << YAML::Value << light.intensity;
    strip << YAML::Key << "change" << YAML::Value << light.change;
    strip << YAML::Key << "camera_spread" << YAML::Value << light.camera_spread;
    if (!light.profile.empty()) {
      strip << YAML::Key << "profile" << YAML::Value << YAML::Flow << light.profile;
      strip << YAML::Comment("relative output along the strip, -sweep_axis end to +sweep_axis end, linear in between");
    }
    LOOM_RETURN_IF_ERROR(EndFile(strip, from, folder / "linear_light.yaml"));
  }
  return Status::Ok();
}

std::vector<double> AsVector(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

Status WriteWheel(const fs::path& folder, const std::string& wheel, const Radiometry& r, const std::string& from) {
  YAML::Emitter out;
  BeginFile(out, "filter_wheel", wheel, kWheelModel, r);
  out << YAML::Key << "slots" << YAML::Value << YAML::BeginSeq;
  for (const FilterRadiometry& f : r.filters) {
    if (f.wheel != wheel) continue;
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "slot" << YAML::Value << f.slot << YAML::Key << "center_nm" << YAML::Value
        << f.center_nm << YAML::Key << "weights" << YAML::Value << YAML::Flow << AsVector(f.weights) << YAML::Key
        << "nominal_weights" << YAML::Value << YAML::Flow << AsVector(f.nominal_weights) << YAML::Key << "fit_residual"
        << YAML::Value << f.fit_residual << YAML::EndMap;
  }
  out << YAML::EndSeq;
  for (const WheelColour& colour : r.wheels) {
    if (colour.wheel != wheel) continue;
    out << YAML::Key << "colour_matrix_slots" << YAML::Value << YAML::Flow << colour.slots;
    out << YAML::Key << "colour_matrix" << YAML::Value << YAML::BeginSeq;
    for (int row = 0; row < 3; ++row) {
      const Eigen::VectorXd values = colour.colour_matrix.row(row).transpose();
      out << YAML::Flow << std::vector<double>(values.data(), values.data() + values.size());
    }
    out << YAML::EndSeq;
    out << YAML::Key << "chart" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "rms_albedo" << YAML::Value
        << colour.chart_rms << YAML::Key << "max_albedo" << YAML::Value << colour.chart_max << YAML::EndMap;
  }
  return EndFile(out, from, folder / (wheel + ".yaml"));
}

// Opens a file, checks its header and reads the fields every file shares.
struct OpenedFile {
  ConfigDocument doc;
  ConfigNode root;
};

Result<OpenedFile> Open(const fs::path& path, const std::string& device, const std::string& name, const char* model,
                        Radiometry* r) {
  if (!fs::exists(path)) return NotFoundError(path.string(), "no such file: the radiometric calibration needs every device's");
  LOOM_ASSIGN_OR_RETURN(ConfigDocument doc, ConfigDocument::LoadFile(path, kSchemaVersion));
  const ConfigNode root = doc.root();
  internal::ReadHeader(root, device, model, name);
  root.Required("reference_camera", &r->reference_camera);
  root.Required("white_albedo", &r->white_albedo);
  internal::ReadSource(root);
  return OpenedFile{std::move(doc), root};
}

// A flat field must be the camera's size, finite and positive: it divides every reading.
Result<std::shared_ptr<const Image>> ReadFlatField(const fs::path& path, const CameraModel& camera) {
  LOOM_ASSIGN_OR_RETURN(ExrImage file, ReadExr(path, {.channels = {"flat"}}));
  const Image& flat = file.image;
  if (flat.width() != camera.width || flat.height() != camera.height) {
    return InvalidArgumentError(path.string(), "is " + std::to_string(flat.width()) + " x " + std::to_string(flat.height()) +
                                                   " px, camera '" + camera.name + "' " + std::to_string(camera.width) + " x " +
                                                   std::to_string(camera.height));
  }
  for (float v : flat.channel(0)) {
    if (!(std::isfinite(v) && v > 0.05f && v < 20.0f)) {
      return InvalidArgumentError(
          path.string(), "holds a value of " + std::to_string(v) + ": a flat field's values must be finite, in (0.05, 20)");
    }
  }
  return std::shared_ptr<const Image>(std::make_shared<Image>(std::move(file.image)));
}

Status ReadCamera(const fs::path& folder, const CameraModel& camera, Radiometry* r) {
  LOOM_ASSIGN_OR_RETURN(OpenedFile file, Open(folder / (camera.name + ".yaml"), "camera", camera.name, kCameraModel, r));
  CameraRadiometry c;
  c.name = camera.name;
  file.root.Required("sensitivity", &c.sensitivity);
  file.root.Required("sensitivity_change", &c.sensitivity_change);
  file.root.Required("vignetting", &c.vignetting);
  file.root.Required("black_dn", &c.black_dn);
  file.root.Required("read_noise_dn", &c.read_noise_dn);
  std::string flat_file;
  file.root.Optional("flat_field", &flat_file);
  file.root.Ignore("quality");  // how well it fitted: for people
  if (!(c.sensitivity > 0)) file.root.AddError("sensitivity", "must be > 0");
  LOOM_RETURN_IF_ERROR(file.doc.Finish());
  if (!flat_file.empty()) {
    LOOM_ASSIGN_OR_RETURN(c.flat_field, ReadFlatField(folder / flat_file, camera));
  }
  r->cameras.push_back(c);
  return Status::Ok();
}

Status ReadLeds(const fs::path& folder, const RigModel& rig, Radiometry* r) {
  const fs::path path = folder / "leds.yaml";
  LOOM_ASSIGN_OR_RETURN(OpenedFile file, Open(path, "leds", "leds", kLedModel, r));
  file.root.Ignore("falloff");
  file.root.Required("tile_subtends_deg", &r->tile_subtends_deg);
  const std::vector<ConfigNode> leds = file.root.Sequence("leds");
  for (const ConfigNode& node : leds) {
    LightRadiometry light;
    node.Required("index", &light.led);
    node.Required("intensity", &light.intensity);
    node.Required("change", &light.change);
    node.Required("camera_spread", &light.camera_spread);
    light.name = "led " + std::to_string(light.led);
    if (light.led < 0 || light.led >= static_cast<int>(rig.leds.size())) {
      node.AddError("index", "rig '" + rig.name + "' has no LED " + std::to_string(light.led));
    }
    r->lights.push_back(light);
  }
  LOOM_RETURN_IF_ERROR(file.doc.Finish());
  if (leds.size() != rig.leds.size()) {
    return InvalidArgumentError(path.string(), "has " + std::to_string(leds.size()) + " LEDs, rig '" + rig.name + "' has " +
                                                   std::to_string(rig.leds.size()));
  }
  return Status::Ok();
}

Status ReadLinearLight(const fs::path& folder, Radiometry* r) {
  LOOM_ASSIGN_OR_RETURN(OpenedFile file,
                        Open(folder / "linear_light.yaml", "linear_light", "linear_light", kLinearLightModel, r));
  LightRadiometry light;
  light.name = "linear light";
  file.root.Required("intensity_per_mm", &light.intensity);
  file.root.Required("change", &light.change);
  file.root.Required("camera_spread", &light.camera_spread);
  file.root.Optional("profile", &light.profile);
  if (const std::string problem = LinearLightModel::ProfileProblem(light.profile); !problem.empty()) {
    file.root.AddError("profile", problem);
  }
  LOOM_RETURN_IF_ERROR(file.doc.Finish());
  r->lights.push_back(light);
  return Status::Ok();
}

Status ReadWheel(const fs::path& folder, const FilterWheelModel& wheel, Radiometry* r) {
  const fs::path path = folder / (wheel.name + ".yaml");
  LOOM_ASSIGN_OR_RETURN(OpenedFile file, Open(path, "filter_wheel", wheel.name, kWheelModel, r));
  for (const ConfigNode& node : file.root.Sequence("slots")) {
    FilterRadiometry f;
    f.wheel = wheel.name;
    node.Required("slot", &f.slot);
    node.Required("center_nm", &f.center_nm);
    node.Required("weights", &f.weights);
    node.Required("nominal_weights", &f.nominal_weights);
    node.Required("fit_residual", &f.fit_residual);
    if (f.slot < 0 || f.slot >= static_cast<int>(wheel.filters.size()) || wheel.filters[f.slot].open) {
      node.AddError("slot", "wheel '" + wheel.name + "' has no band-pass filter in slot " + std::to_string(f.slot));
    }
    r->filters.push_back(f);
  }
  for (const char* derived : {"colour_matrix_slots", "colour_matrix", "chart"}) file.root.Ignore(derived);  // from the weights
  return file.doc.Finish();
}

}  // namespace

Status WriteRadiometry(const fs::path& directory, const Radiometry& radiometry, const std::string& from) {
  LOOM_RETURN_IF_ERROR(CreateDirectories(directory));
  // A recalibration replaces the folder whole: a run that fails or is killed half-way leaves the
  // old calibration as it was, not some of its files beside new ones.
  LOOM_ASSIGN_OR_RETURN(OutputDirectory staged, OutputDirectory::Replacing(Folder(directory), "radiometric calibration"));
  const fs::path& folder = staged.partial();
  for (const CameraRadiometry& camera : radiometry.cameras) LOOM_RETURN_IF_ERROR(WriteCamera(folder, camera, radiometry, from));
  LOOM_RETURN_IF_ERROR(WriteLights(folder, radiometry, from));
  std::vector<std::string> wheels;
  for (const FilterRadiometry& f : radiometry.filters) {
    if (std::find(wheels.begin(), wheels.end(), f.wheel) == wheels.end()) wheels.push_back(f.wheel);
  }
  for (const std::string& wheel : wheels) LOOM_RETURN_IF_ERROR(WriteWheel(folder, wheel, radiometry, from));
  return staged.Commit();
}

Result<Radiometry> ReadRadiometry(const fs::path& directory, const RigModel& rig) {
  const fs::path folder = Folder(directory);
  if (!fs::is_directory(folder)) return NotFoundError(folder.string(), "no radiometric calibration (loom calibrate radiometry)");
  Radiometry radiometry;
  for (const CameraModel& camera : rig.cameras) LOOM_RETURN_IF_ERROR(ReadCamera(folder, camera, &radiometry));
  LOOM_RETURN_IF_ERROR(ReadLeds(folder, rig, &radiometry));
  if (rig.linear_light) LOOM_RETURN_IF_ERROR(ReadLinearLight(folder, &radiometry));
  for (const FilterWheelModel& wheel : rig.filter_wheels) LOOM_RETURN_IF_ERROR(ReadWheel(folder, wheel, &radiometry));
  return radiometry;
}

Result<std::optional<Radiometry>> ApplyRadiometryCalibration(const fs::path& directory, RigModel* rig) {
  if (!fs::is_directory(Folder(directory))) return std::optional<Radiometry>();
  LOOM_ASSIGN_OR_RETURN(Radiometry radiometry, ReadRadiometry(directory, *rig));
  ApplyRadiometry(radiometry, rig);
  return std::optional<Radiometry>(std::move(radiometry));
}

}  // namespace loom::calibration
