#include "core/rig_model.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace loom {
namespace {

// More LEDs than any dome holds: a bound so that a typo (count: 2000000000) is an error, not an
// allocation without end.
constexpr int kMaxLedsPerRing = 4096;
// The largest sensor or projector side a rig may declare (today's largest sensors are ~14 k px).
constexpr int kMaxSensorSide = 65536;

// cam_from_rig for a camera at `position` looking at `target`, with `up` appearing up in the
// image (OpenCV axes: x right, y down, z forward).
Rigid3d LookAt(const Eigen::Vector3d& position, const Eigen::Vector3d& target, const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (target - position).normalized();
  const Eigen::Vector3d y = -(up - up.dot(z) * z).normalized();
  const Eigen::Vector3d x = y.cross(z);
  Eigen::Matrix3d r;
  r.row(0) = x.transpose();
  r.row(1) = y.transpose();
  r.row(2) = z.transpose();
  return MakeRigid(r, -r * position);
}

// A rig's quantities are physical: each is refused outside the range a real device can have
// (or that the models assume), naming its key, rather than surfacing later as NaN or a hang.
void CheckIn(const ConfigNode& node, std::string_view key, double value, double low, double high, bool low_open = false) {
  const bool above = low_open ? value > low : value >= low;
  if (above && value <= high) return;
  std::ostringstream range;
  range << "must be in " << (low_open ? "(" : "[") << low << ", " << high << "]";
  node.AddError(key, range.str());
}

void ReadSensor(const ConfigNode& node, SensorModel* sensor) {
  node.Optional("adc_bits", &sensor->adc_bits);
  node.Optional("dark_offset_dn", &sensor->dark_offset_dn);
  node.Optional("read_noise_e", &sensor->read_noise_e);
  node.Optional("full_well_e", &sensor->full_well_e);
  node.Optional("sensitivity", &sensor->sensitivity);
  node.Optional("vignetting", &sensor->vignetting);
  if (sensor->adc_bits < 8 || sensor->adc_bits > 16) node.AddError("adc_bits", "must be 8..16");
  CheckIn(node, "full_well_e", sensor->full_well_e, 0, 1e8, true);
  if (sensor->adc_bits >= 8 && sensor->adc_bits <= 16)
    CheckIn(node, "dark_offset_dn", sensor->dark_offset_dn, 0, (1 << sensor->adc_bits) - 2);
  CheckIn(node, "read_noise_e", sensor->read_noise_e, 0, 1e4);
  CheckIn(node, "sensitivity", sensor->sensitivity, 0, 1e15, true);
  CheckIn(node, "vignetting", sensor->vignetting, 0, 0.99);
}

// Reads a pinhole pose and intrinsics shared by cameras and the projector.
void ReadPinhole(const ConfigNode& node, int* width, int* height, Eigen::Matrix3d* k, Rigid3d* from_rig) {
  std::vector<int> resolution;
  Eigen::Vector2d focal(1, 1), principal(0, 0);
  Eigen::Vector3d position = Eigen::Vector3d::UnitZ(), look_at = Eigen::Vector3d::Zero(), up = Eigen::Vector3d::UnitY();
  node.Required("resolution", &resolution);
  node.Required("focal_px", &focal);
  node.Optional("principal_px", &principal);
  node.Required("position_mm", &position);
  node.Optional("look_at_mm", &look_at);
  node.Optional("up", &up);
  if (resolution.size() == 2 && resolution[0] >= 1 && resolution[1] >= 1 && resolution[0] <= kMaxSensorSide &&
      resolution[1] <= kMaxSensorSide) {
    *width = resolution[0];
    *height = resolution[1];
  } else {
    node.AddError("resolution", "expected [width, height], each in [1, " + std::to_string(kMaxSensorSide) + "]");
  }
  CheckIn(node, "focal_px", std::min(focal.x(), focal.y()), 0, 1e7, true);
  CheckIn(node, "focal_px", std::max(focal.x(), focal.y()), 0, 1e7, true);
  if ((look_at - position).cross(up).norm() < 1e-9 * std::max(1.0, (look_at - position).norm())) {
    node.AddError("up", "must not be parallel to the viewing direction (nor zero)");
  }
  if (!node.Has("principal_px")) principal = {(*width - 1) / 2.0, (*height - 1) / 2.0};
  *k << focal.x(), 0, principal.x(), 0, focal.y(), principal.y(), 0, 0, 1;
  if ((look_at - position).norm() < 1e-9) node.AddError("look_at_mm", "must differ from position_mm");
  *from_rig = LookAt(position, look_at, up);
}

}  // namespace

bool CameraModel::Project(const Eigen::Vector3d& p, Eigen::Vector2d* pixel) const {
  if (p.z() <= 0) return false;
  const double x = p.x() / p.z();
  const double y = p.y() / p.z();
  const double r2 = x * x + y * y;
  const auto& d = distortion;
  const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
  const double xd = x * radial + 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
  const double yd = y * radial + d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
  *pixel = {K(0, 0) * xd + K(0, 2), K(1, 1) * yd + K(1, 2)};
  return true;
}

Eigen::Vector3d CameraModel::Unproject(const Eigen::Vector2d& pixel) const {
  const double xd = (pixel.x() - K(0, 2)) / K(0, 0);
  const double yd = (pixel.y() - K(1, 2)) / K(1, 1);
  const auto& d = distortion;
  double x = xd, y = yd;
  // Fixed-point inversion, as OpenCV's undistortPoints: 20 iterations, or fewer where an
  // iteration no longer changes x and y (every later one would repeat it: the same answer).
  for (int i = 0; i < 20; ++i) {
    const double r2 = x * x + y * y;
    const double radial = 1 + d[0] * r2 + d[1] * r2 * r2 + d[4] * r2 * r2 * r2;
    const double dx = 2 * d[2] * x * y + d[3] * (r2 + 2 * x * x);
    const double dy = d[2] * (r2 + 2 * y * y) + 2 * d[3] * x * y;
    const double next_x = (xd - dx) / radial, next_y = (yd - dy) / radial;
    if (next_x == x && next_y == y) break;
    x = next_x;
    y = next_y;
  }
  return Eigen::Vector3d(x, y, 1).normalized();
}

double LedModel::IntensityTowards(const Eigen::Vector3d& point_in_rig, double current_ma) const {
  const double c = axis.dot((point_in_rig - position_mm).normalized());
  if (c <= 0 || current_ma <= 0) return 0;
  return intensity * (current_ma / 1000.0) * CosinePower(c, falloff_exponent);
}

Eigen::Vector3d LinearLightModel::StripCentre(double position_mm) const {
  const double angle = DegToRad(start_deg + (end_deg - start_deg) * position_mm / travel_mm);
  return arm_radius_mm * (Eigen::AngleAxisd(angle, sweep_axis.normalized()) * Eigen::Vector3d::UnitZ());
}

Eigen::Vector3d LinearLightModel::StripNormal(double position_mm) const { return -StripCentre(position_mm).normalized(); }

std::string LinearLightModel::ProfileProblem(const std::vector<double>& profile) {
  const bool valid = profile.empty() || (profile.size() >= 2 && profile.size() <= 64 &&
                                         std::ranges::all_of(profile, [](double v) { return v > 0 && v <= 10; }));
  return valid ? "" : "must be 2 to 64 relative outputs, each in (0, 10]";
}

double LinearLightModel::ProfileAt(double along_mm) const {
  if (profile.size() < 2) return profile.empty() ? 1.0 : profile.front();
  const double t = std::clamp((along_mm / strip_length_mm + 0.5) * (profile.size() - 1), 0.0, profile.size() - 1.0);
  const size_t k = std::min(static_cast<size_t>(t), profile.size() - 2);
  return profile[k] + (t - k) * (profile[k + 1] - profile[k]);
}

Rigid3d TurntableModel::RigFromSample(double angle_deg) const {
  return RotationAboutAxis(axis_point_mm, axis_direction, DegToRad(angle_deg));
}

Rigid3d CalibrationTargetModel::SampleFromBoard() const {
  return MakeRigid(Eigen::AngleAxisd(DegToRad(tilt_deg), Eigen::Vector3d::UnitX()).toRotationMatrix(),
                   Eigen::Vector3d(0, 0, centre_height_mm));
}

std::vector<Eigen::Vector3d> CalibrationTargetModel::CornersInBoard() const {
  std::vector<Eigen::Vector3d> corners;
  for (int r = 0; r < inner_rows; ++r) {
    for (int c = 0; c < inner_cols; ++c) {
      corners.emplace_back((c - (inner_cols - 1) / 2.0) * square_mm, (r - (inner_rows - 1) / 2.0) * square_mm, 0);
    }
  }
  return corners;
}

double SensorModel::QuadraticResponse(double x, double y, int width, int height) const {
  const double corner2 = 0.25 * (static_cast<double>(width) * width + static_cast<double>(height) * height);
  const double dx = x - (width - 1) / 2.0;
  const double dy = y - (height - 1) / 2.0;
  return 1 - vignetting * (dx * dx + dy * dy) / corner2;
}

double SensorModel::RelativeResponse(double x, double y, int width, int height) const {
  const double quadratic = QuadraticResponse(x, y, width, height);
  if (!flat_field) return quadratic;
  const int px = static_cast<int>(std::lround(x)), py = static_cast<int>(std::lround(y));
  if (px < 0 || py < 0 || px >= flat_field->width() || py >= flat_field->height()) return quadratic;
  return quadratic * flat_field->at(0, py, px);
}

std::optional<int> FilterWheelModel::OpenSlot() const {
  for (size_t slot = 0; slot < filters.size(); ++slot) {
    if (filters[slot].open) return static_cast<int>(slot);
  }
  return std::nullopt;
}

const CameraModel* RigModel::FindCamera(const std::string& camera_name) const {
  for (const CameraModel& camera : cameras) {
    if (camera.name == camera_name) return &camera;
  }
  return nullptr;
}

const FilterWheelModel* RigModel::WheelOfLed(int led) const {
  for (const FilterWheelModel& wheel : filter_wheels) {
    if (wheel.led == led) return &wheel;
  }
  return nullptr;
}

RigModel ReadRigModel(const ConfigNode& geometry) {
  RigModel rig;
  geometry.Optional("sample_holder_diameter_mm", &rig.sample_holder_diameter_mm);
  CheckIn(geometry, "sample_holder_diameter_mm", rig.sample_holder_diameter_mm, 0, 1e4, true);
  if (std::optional<ConfigNode> turntable = geometry.OptionalChild("turntable")) {
    turntable->Optional("axis_point_mm", &rig.turntable.axis_point_mm);
    turntable->Optional("axis_direction", &rig.turntable.axis_direction);
    if (rig.turntable.axis_direction.norm() < 1e-9) turntable->AddError("axis_direction", "must not be zero");
    rig.turntable.axis_direction.normalize();
  }
  for (const ConfigNode& node : geometry.Sequence("cameras")) {
    CameraModel camera;
    node.Required("name", &camera.name);
    ReadPinhole(node, &camera.width, &camera.height, &camera.K, &camera.cam_from_rig);
    std::vector<double> distortion;
    node.Optional("distortion", &distortion);
    if (distortion.size() == 5) {
      camera.distortion = Eigen::Map<const Eigen::Matrix<double, 5, 1>>(distortion.data());
    } else if (!distortion.empty()) {
      node.AddError("distortion", "expected [k1, k2, p1, p2, k3]");
    }
    if (std::optional<ConfigNode> sensor = node.OptionalChild("sensor")) ReadSensor(*sensor, &camera.sensor);
    if (camera.name.empty()) node.AddError("name", "must not be empty");
    if (rig.FindCamera(camera.name) != nullptr) node.AddError("name", "'" + camera.name + "' names two cameras");
    rig.cameras.push_back(camera);
  }
  // LEDs by ring (elevation, count, azimuth offset on a dome), then any listed one by one
  // (e.g. calibrated positions). Indices follow this order.
  for (const ConfigNode& node : geometry.OptionalSequence("led_rings")) {
    double radius_mm = 650, elevation_deg = 45, azimuth_offset_deg = 0, intensity = 1e6, falloff = 1;
    int count = 1;
    node.Required("radius_mm", &radius_mm);
    node.Required("elevation_deg", &elevation_deg);
    node.Required("count", &count);
    node.Optional("azimuth_offset_deg", &azimuth_offset_deg);
    node.Optional("intensity", &intensity);
    node.Optional("falloff_exponent", &falloff);
    if (count < 1 || count > kMaxLedsPerRing) {
      node.AddError("count", "must be in [1, " + std::to_string(kMaxLedsPerRing) + "]");
      count = 0;
    }
    if (!(radius_mm > 0)) node.AddError("radius_mm", "must be > 0");
    CheckIn(node, "elevation_deg", elevation_deg, -90, 90);
    CheckIn(node, "intensity", intensity, 0, 1e15);
    CheckIn(node, "falloff_exponent", falloff, 0, 1000);
    for (int i = 0; i < count; ++i) {
      LedModel led;
      const double azimuth = DegToRad(azimuth_offset_deg + 360.0 * i / count);
      led.position_mm = radius_mm * DirectionFromSpherical(DegToRad(90 - elevation_deg), azimuth);
      led.axis = -led.position_mm.normalized();
      led.intensity = intensity;
      led.falloff_exponent = falloff;
      rig.leds.push_back(led);
    }
  }
  for (const ConfigNode& node : geometry.OptionalSequence("leds")) {
    LedModel led;
    node.Required("position_mm", &led.position_mm);
    node.Optional("intensity", &led.intensity);
    node.Optional("falloff_exponent", &led.falloff_exponent);
    // By default an LED points at the rig origin (the sample centre).
    led.axis = -led.position_mm.normalized();
    node.Optional("axis", &led.axis);
    if (led.position_mm.norm() < 1e-9) node.AddError("position_mm", "must not be the sample's centre");
    if (led.axis.norm() < 1e-9) node.AddError("axis", "must not be zero");
    CheckIn(node, "intensity", led.intensity, 0, 1e15);
    CheckIn(node, "falloff_exponent", led.falloff_exponent, 0, 1000);
    led.axis.normalize();
    rig.leds.push_back(led);
  }
  if (rig.leds.empty()) geometry.AddError("led_rings", "the rig has no LEDs (give led_rings or leds)");
  if (std::optional<ConfigNode> node = geometry.OptionalChild("linear_light")) {
    LinearLightModel light;
    node->Required("arm_radius_mm", &light.arm_radius_mm);
    node->Required("strip_length_mm", &light.strip_length_mm);
    node->Optional("sweep_axis", &light.sweep_axis);
    node->Required("start_deg", &light.start_deg);
    node->Required("end_deg", &light.end_deg);
    node->Required("travel_mm", &light.travel_mm);
    node->Optional("intensity_per_mm", &light.intensity_per_mm);
    node->Optional("falloff_exponent", &light.falloff_exponent);
    node->Optional("segments", &light.segments);
    node->Optional("profile", &light.profile);
    if (light.sweep_axis.norm() < 1e-9) node->AddError("sweep_axis", "must not be zero");
    light.sweep_axis.normalize();
    CheckIn(*node, "arm_radius_mm", light.arm_radius_mm, 0, 1e5, true);
    CheckIn(*node, "strip_length_mm", light.strip_length_mm, 0, 1e5, true);
    CheckIn(*node, "intensity_per_mm", light.intensity_per_mm, 0, 1e15);
    CheckIn(*node, "falloff_exponent", light.falloff_exponent, 0, 1000);
    if (const std::string problem = LinearLightModel::ProfileProblem(light.profile); !problem.empty()) {
      node->AddError("profile", problem);
    }
    if (light.travel_mm <= 0) node->AddError("travel_mm", "must be > 0");
    if (light.segments < 1 || light.segments > 1024) node->AddError("segments", "must be in [1, 1024]");
    rig.linear_light = light;
  }
  if (std::optional<ConfigNode> node = geometry.OptionalChild("projector")) {
    ProjectorModel projector;
    ReadPinhole(*node, &projector.width, &projector.height, &projector.K, &projector.proj_from_rig);
    node->Optional("max_intensity", &projector.max_intensity);
    CheckIn(*node, "max_intensity", projector.max_intensity, 0, 1e15, true);
    rig.projector = projector;
  }
  if (std::optional<ConfigNode> node = geometry.OptionalChild("calibration_target")) {
    CalibrationTargetModel target;
    std::vector<int> inner;
    node->Required("inner_corners", &inner);
    node->Required("square_mm", &target.square_mm);
    node->Required("tilt_deg", &target.tilt_deg);
    node->Required("centre_height_mm", &target.centre_height_mm);
    if (inner.size() == 2 && inner[0] >= 2 && inner[1] >= 2) {
      target.inner_cols = inner[0];
      target.inner_rows = inner[1];
    } else {
      node->AddError("inner_corners", "expected [COLS, ROWS], each ≥ 2");
    }
    if (!(target.square_mm > 0)) node->AddError("square_mm", "must be > 0");
    if (!(target.tilt_deg >= 0 && target.tilt_deg < 80)) node->AddError("tilt_deg", "must be in [0, 80)");
    rig.calibration_target = target;
  }
  if (std::optional<ConfigNode> node = geometry.OptionalChild("white_reference")) {
    node->Required("albedo", &rig.white_reference.albedo);
    if (!(rig.white_reference.albedo > 0 && rig.white_reference.albedo <= 1)) node->AddError("albedo", "must be in (0, 1]");
    node->Optional("spacer_mm", &rig.white_reference.spacer_mm);
    if (!(rig.white_reference.spacer_mm >= 0)) node->AddError("spacer_mm", "must be >= 0");
  }
  if (std::optional<ConfigNode> node = geometry.OptionalChild("colour_chart")) {
    node->Required("patch_mm", &rig.colour_chart.patch_mm);
    if (!(rig.colour_chart.patch_mm > 0)) node->AddError("patch_mm", "must be > 0");
  }
  if (std::optional<ConfigNode> node = geometry.OptionalChild("light_probe")) {
    LightProbeModel probe;
    node->Required("radius_mm", &probe.radius_mm);
    if (!(probe.radius_mm > 0)) node->AddError("radius_mm", "must be > 0");
    rig.light_probe = probe;
  }
  for (const ConfigNode& node : geometry.OptionalSequence("filter_wheels")) {
    FilterWheelModel wheel;
    node.Required("name", &wheel.name);
    node.Required("led", &wheel.led);
    if (wheel.led < 0 || wheel.led >= static_cast<int>(rig.leds.size())) {
      node.AddError("led", "no LED " + std::to_string(wheel.led));
    }
    for (const ConfigNode& filter_node : node.Sequence("filters")) {
      FilterModel filter;
      filter_node.Optional("open", &filter.open);
      if (filter.open) {
        wheel.filters.push_back(filter);
        continue;
      }
      filter_node.Required("center_nm", &filter.center_nm);
      filter_node.Optional("fwhm_nm", &filter.fwhm_nm);
      filter_node.Optional("peak_transmission", &filter.peak_transmission);
      CheckIn(filter_node, "center_nm", filter.center_nm, 200, 2000);
      CheckIn(filter_node, "fwhm_nm", filter.fwhm_nm, 0, 2000, true);
      CheckIn(filter_node, "peak_transmission", filter.peak_transmission, 0, 1, true);
      wheel.filters.push_back(filter);
    }
    rig.filter_wheels.push_back(wheel);
  }
  return rig;
}

}  // namespace loom
