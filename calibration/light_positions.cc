#include "calibration/light_positions.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "calibration/internal/provenance.h"
#include "core/config.h"
#include "core/file_io.h"

namespace loom::calibration {
namespace {

namespace fs = std::filesystem;

constexpr int kSchemaVersion = 1;
constexpr char kModel[] =
    "LED positions in the rig frame (mm) and the linear light's sweep angles (deg) from a chrome sphere's highlights; "
    "distances and the arm's radius kept nominal";
constexpr int kWindowPx = 6;

// The highlight's centroid: pixels within kWindowPx of the brightest, weighted by how far they
// rise above a tenth of it.
Result<Eigen::Vector2d> Highlight(const LitView& view) {
  const Image& radiance = view.radiance;
  const SeenPixels seen = SeenPixelsOf(view);
  int best_x = -1, best_y = -1;
  float best = 0;
  for (int y = seen.y0; y < seen.y1; ++y) {
    for (int x = seen.x0; x < seen.x1; ++x) {
      const float v = radiance.at(0, y, x);
      if (std::isnan(v)) return FailedPreconditionError(view.source, "the highlight saturated in every exposure");
      if (v > best) {
        best = v;
        best_x = x;
        best_y = y;
      }
    }
  }
  if (best_x < 0) return FailedPreconditionError(view.source, "no highlight: the view is dark");
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double weights = 0;
  for (int y = std::max(seen.y0, best_y - kWindowPx); y <= std::min(seen.y1 - 1, best_y + kWindowPx); ++y) {
    for (int x = std::max(seen.x0, best_x - kWindowPx); x <= std::min(seen.x1 - 1, best_x + kWindowPx); ++x) {
      const double w = radiance.at(0, y, x) - 0.1 * best;
      if (w <= 0) continue;
      sum += w * Eigen::Vector2d(x, y);
      weights += w;
    }
  }
  return Eigen::Vector2d(sum / weights);
}

struct LedRay {
  Eigen::Vector3d origin;     // on the sphere, rig frame
  Eigen::Vector3d direction;  // unit, towards the LED
};

// The camera's ray through the highlight, mirrored on the sphere.
Result<LedRay> MirroredRay(const RigModel& rig, const LightProbeModel& probe, const LitView& view, const Eigen::Vector2d& pixel) {
  const CameraModel& camera = rig.cameras[view.camera];
  const Rigid3d rig_from_sample = rig.turntable.RigFromSample(view.lighting.turntable_deg);
  const Rigid3d rig_from_cam = camera.cam_from_rig.inverse();
  const Eigen::Vector3d eye = rig_from_cam.translation();
  const Eigen::Vector3d ray = (rig_from_cam.linear() * camera.Unproject(pixel)).normalized();
  const Eigen::Vector3d centre = rig_from_sample * probe.CentreInSample();
  // |eye + t·ray − centre| = r, the nearer root.
  const Eigen::Vector3d to_eye = eye - centre;
  const double b = ray.dot(to_eye);
  const double discriminant = b * b - (to_eye.squaredNorm() - probe.radius_mm * probe.radius_mm);
  if (discriminant < 0) return FailedPreconditionError(view.source, "the highlight is not on the light probe's sphere");
  const Eigen::Vector3d hit = eye + (-b - std::sqrt(discriminant)) * ray;
  const Eigen::Vector3d normal = (hit - centre).normalized();
  const Eigen::Vector3d to_viewer = -ray;
  return LedRay{hit, (2 * normal.dot(to_viewer) * normal - to_viewer).normalized()};
}

// Where a ray from near the sphere reaches `distance` from its centre.
Eigen::Vector3d AtDistance(const LedRay& ray, const Eigen::Vector3d& centre, double distance) {
  const Eigen::Vector3d from_centre = ray.origin - centre;
  const double b = ray.direction.dot(from_centre);
  const double s = -b + std::sqrt(std::max(0.0, b * b - (from_centre.squaredNorm() - distance * distance)));
  return ray.origin + s * ray.direction;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return RadToDeg(std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)));
}

LightPosition Triangulate(const RigModel& rig, int led, const std::vector<LedRay>& rays) {
  const Eigen::Vector3d centre = rig.turntable.RigFromSample(0) * rig.light_probe->CentreInSample();
  const Eigen::Vector3d nominal = rig.leds[led].position_mm;
  LightPosition result;
  result.led = led;
  result.views = static_cast<int>(rays.size());
  for (const LedRay& ray : rays) result.position_mm += AtDistance(ray, centre, (nominal - centre).norm()) / rays.size();
  for (const LedRay& ray : rays) {
    result.residual_deg = std::max(result.residual_deg, AngleDeg(ray.direction, result.position_mm - ray.origin));
  }
  result.change_deg = AngleDeg(result.position_mm - centre, nominal - centre);
  result.change_mm = (result.position_mm - nominal).norm();
  return result;
}

// The arm's angle about the sweep axis where a ray from near the sphere meets the cylinder the
// strip moves on (the arm's radius about the axis through the rig's origin, the arm's pivot).
double ArmAngleDeg(const LinearLightModel& strip, const LedRay& ray) {
  const Eigen::Vector3d axis = strip.sweep_axis.normalized();
  const auto across = [&](const Eigen::Vector3d& v) -> Eigen::Vector3d { return v - axis.dot(v) * axis; };
  const Eigen::Vector3d origin = across(ray.origin), direction = across(ray.direction);
  // |origin + s·direction| = radius, the far root.
  const double a = direction.squaredNorm(), b = origin.dot(direction);
  const double c = origin.squaredNorm() - strip.arm_radius_mm * strip.arm_radius_mm;
  const Eigen::Vector3d point = origin + (-b + std::sqrt(std::max(0.0, b * b - a * c))) / a * direction;
  const Eigen::Vector3d zenith = across(Eigen::Vector3d::UnitZ()).normalized();  // the arm at 0°
  return RadToDeg(std::atan2(point.dot(axis.cross(zenith)), point.dot(zenith)));
}

// The arm's angle seen in a view of the sphere under the strip. Every point of the strip has the
// same angle, so every pixel of its streak measures it: the mean over the pixels above a third
// of the brightest, weighted by how far they rise above that. (A centroid would fall inside the
// curved streak, off the strip's reflection: 0.4-0.7° of error here.)
Result<double> StripArmAngleDeg(const RigModel& rig, const LitView& view) {
  const Image& radiance = view.radiance;
  const SeenPixels seen = SeenPixelsOf(view);
  float brightest = 0;
  for (int y = seen.y0; y < seen.y1; ++y) {
    for (int x = seen.x0; x < seen.x1; ++x) {
      const float v = radiance.at(0, y, x);
      if (std::isnan(v)) return FailedPreconditionError(view.source, "the strip's reflection saturated in every exposure");
      brightest = std::max(brightest, v);
    }
  }
  if (brightest <= 0) return FailedPreconditionError(view.source, "no reflection of the strip: the view is dark");
  double sum = 0, weights = 0;
  for (int y = seen.y0; y < seen.y1; ++y) {
    for (int x = seen.x0; x < seen.x1; ++x) {
      const double w = radiance.at(0, y, x) - brightest / 3.0;
      if (w <= 0) continue;
      const Result<LedRay> ray = MirroredRay(rig, *rig.light_probe, view, Eigen::Vector2d(x, y));
      if (!ray.ok()) continue;  // a pixel of the streak's blur beside the sphere's rim
      sum += w * ArmAngleDeg(*rig.linear_light, *ray);
      weights += w;
    }
  }
  if (weights <= 0) return FailedPreconditionError(view.source, "the strip's reflection is not on the light probe's sphere");
  return sum / weights;
}

struct StripAngle {
  double carriage_mm;
  double angle_deg;
};

// angle = start + (end − start)·carriage/travel through the views' arm angles, least squares.
Result<LinearLightSweep> FitSweep(const LinearLightModel& strip, const std::vector<StripAngle>& measured) {
  Eigen::MatrixXd design(measured.size(), 2);
  Eigen::VectorXd angles(measured.size());
  for (size_t i = 0; i < measured.size(); ++i) {
    const double t = measured[i].carriage_mm / strip.travel_mm;
    design.row(i) << 1 - t, t;
    angles[i] = measured[i].angle_deg;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(design, Eigen::ComputeThinU | Eigen::ComputeThinV);
  if (svd.rank() < 2) {
    return FailedPreconditionError("linear light", "light-probe views at one carriage position: the sweep needs two or more");
  }
  const Eigen::Vector2d ends = svd.solve(angles);
  LinearLightSweep sweep;
  sweep.start_deg = ends[0];
  sweep.end_deg = ends[1];
  sweep.change_deg = std::max(std::abs(ends[0] - strip.start_deg), std::abs(ends[1] - strip.end_deg));
  sweep.residual_deg = (design * ends - angles).cwiseAbs().maxCoeff();
  sweep.views = static_cast<int>(measured.size());
  return sweep;
}

}  // namespace

Result<LightPositions> CalibrateLightPositions(const RigModel& rig, const std::vector<LitView>& views) {
  if (!rig.light_probe) return FailedPreconditionError("rig '" + rig.name + "'", "has no light_probe: what the chrome sphere is");
  std::map<int, std::vector<LedRay>> rays;
  std::vector<StripAngle> strip_angles;
  for (const LitView& view : views) {
    if (view.lighting.linear_light_on && view.lighting.leds.empty() && rig.linear_light) {
      LOOM_ASSIGN_OR_RETURN(const double angle_deg, StripArmAngleDeg(rig, view));
      strip_angles.push_back({view.lighting.linear_light_mm, angle_deg});
      continue;
    }
    if (view.lighting.leds.size() != 1 || view.lighting.linear_light_on) {
      return InvalidArgumentError(view.source, "a light-probe view must be lit by one LED or the linear light alone");
    }
    LOOM_ASSIGN_OR_RETURN(const Eigen::Vector2d pixel, Highlight(view));
    LOOM_ASSIGN_OR_RETURN(const LedRay ray, MirroredRay(rig, *rig.light_probe, view, pixel));
    rays[view.lighting.leds.front().first].push_back(ray);
  }
  LightPositions positions;
  positions.probe_radius_mm = rig.light_probe->radius_mm;
  for (int led = 0; led < static_cast<int>(rig.leds.size()); ++led) {
    if (!rays.contains(led)) return NotFoundError("led " + std::to_string(led), "has no light-probe view");
    positions.leds.push_back(Triangulate(rig, led, rays[led]));
  }
  if (!strip_angles.empty()) {
    LOOM_ASSIGN_OR_RETURN(positions.linear_light, FitSweep(*rig.linear_light, strip_angles));
  }
  return positions;
}

void ApplyLightPositions(const LightPositions& positions, RigModel* rig) {
  for (const LightPosition& led : positions.leds) {
    if (led.led >= 0 && led.led < static_cast<int>(rig->leds.size())) rig->leds[led.led].position_mm = led.position_mm;
  }
  if (positions.linear_light && rig->linear_light) {
    rig->linear_light->start_deg = positions.linear_light->start_deg;
    rig->linear_light->end_deg = positions.linear_light->end_deg;
  }
}

Status WriteLightPositions(const fs::path& directory, const LightPositions& positions, const std::string& from) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);  // doubles round-trip exactly
  out << YAML::BeginMap;
  out << YAML::Key << "schema_version" << YAML::Value << kSchemaVersion;
  out << YAML::Key << "device" << YAML::Value << "lights";
  out << YAML::Key << "name" << YAML::Value << "lights";
  out << YAML::Key << "model" << YAML::Value << kModel;
  out << YAML::Key << "probe_radius_mm" << YAML::Value << positions.probe_radius_mm;
  out << YAML::Key << "leds" << YAML::Value << YAML::BeginSeq;
  for (const LightPosition& led : positions.leds) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "index" << YAML::Value << led.led << YAML::Key << "position_mm"
        << YAML::Value << YAML::Flow << std::vector<double>{led.position_mm.x(), led.position_mm.y(), led.position_mm.z()}
        << YAML::Key << "change_deg" << YAML::Value << led.change_deg << YAML::Key << "change_mm" << YAML::Value << led.change_mm
        << YAML::Key << "residual_deg" << YAML::Value << led.residual_deg << YAML::Key << "views" << YAML::Value << led.views
        << YAML::EndMap;
  }
  out << YAML::EndSeq;
  if (const std::optional<LinearLightSweep>& sweep = positions.linear_light) {
    out << YAML::Key << "linear_light" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "start_deg" << YAML::Value
        << sweep->start_deg << YAML::Key << "end_deg" << YAML::Value << sweep->end_deg << YAML::Key << "change_deg" << YAML::Value
        << sweep->change_deg << YAML::Key << "residual_deg" << YAML::Value << sweep->residual_deg << YAML::Key << "views"
        << YAML::Value << sweep->views << YAML::EndMap;
  }
  internal::EmitSource(out, from);
  out << YAML::EndMap;
  return WriteFileAtomically(directory / "light_positions.yaml", std::string(out.c_str()) + "\n");
}

Result<bool> ApplyLightPositionCalibration(const fs::path& directory, RigModel* rig) {
  const fs::path path = directory / "light_positions.yaml";
  if (!fs::exists(path)) return false;
  LOOM_ASSIGN_OR_RETURN(const ConfigDocument doc, ConfigDocument::LoadFile(path, kSchemaVersion));
  const ConfigNode root = doc.root();
  internal::ReadHeader(root, "lights", kModel);
  LightPositions positions;
  root.Required("probe_radius_mm", &positions.probe_radius_mm);
  const std::vector<ConfigNode> leds = root.Sequence("leds");
  for (const ConfigNode& node : leds) {
    LightPosition led;
    node.Required("index", &led.led);
    node.Required("position_mm", &led.position_mm);
    node.Required("change_deg", &led.change_deg);
    node.Required("change_mm", &led.change_mm);
    node.Required("residual_deg", &led.residual_deg);
    node.Required("views", &led.views);
    if (led.led < 0 || led.led >= static_cast<int>(rig->leds.size())) {
      node.AddError("index", "rig '" + rig->name + "' has no LED " + std::to_string(led.led));
    }
    positions.leds.push_back(led);
  }
  if (const std::optional<ConfigNode> node = root.OptionalChild("linear_light")) {
    LinearLightSweep sweep;
    node->Required("start_deg", &sweep.start_deg);
    node->Required("end_deg", &sweep.end_deg);
    node->Required("change_deg", &sweep.change_deg);
    node->Required("residual_deg", &sweep.residual_deg);
    node->Required("views", &sweep.views);
    if (!rig->linear_light) node->AddError("start_deg", "rig '" + rig->name + "' has no linear light");
    positions.linear_light = sweep;
  }
  internal::ReadSource(root);
  LOOM_RETURN_IF_ERROR(doc.Finish());
  if (leds.size() != rig->leds.size()) {
    return InvalidArgumentError(path.string(), "has " + std::to_string(leds.size()) + " LEDs, rig '" + rig->name + "' has " +
                                                   std::to_string(rig->leds.size()));
  }
  ApplyLightPositions(positions, rig);
  return true;
}

}  // namespace loom::calibration
