#include "sim/object_capture.h"

#include <cmath>
#include <numbers>
#include <optional>
#include <random>

#include "fitting/model/svbrdf_maps.h"

namespace loom::sim {
namespace {

// Directions on a golden-angle spiral over the cap within `max_deg` of +z, evenly spread.
std::vector<Eigen::Vector3d> SpiralDirections(int count, double max_deg) {
  const double min_z = std::cos(max_deg * std::numbers::pi / 180);
  const double golden = std::numbers::pi * (3 - std::sqrt(5.0));
  std::vector<Eigen::Vector3d> directions;
  for (int k = 0; k < count; ++k) {
    const double z = 1 - (1 - min_z) * (k + 0.5) / count;
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    directions.emplace_back(r * std::cos(golden * k), r * std::sin(golden * k), z);
  }
  return directions;
}

// The object's normal at image position (u, v) ∈ [−1, 1]² (y up), if it covers it.
std::optional<Eigen::Vector3d> NormalAt(ObjectShape shape, double u, double v) {
  if (shape == ObjectShape::kSphere) {
    const double r2 = u * u + v * v;
    if (r2 >= 1) return std::nullopt;
    return Eigen::Vector3d(u, v, std::sqrt(1 - r2));
  }
  if (std::abs(u) >= 1 || std::abs(v) >= 0.9) return std::nullopt;  // a cylinder along y
  return Eigen::Vector3d(u, 0, std::sqrt(1 - u * u));
}

// The material at image position (u, v) (y up) in the stack frame (y down), if the object covers
// it: its own normal, and a_d modulated in stripes so that the albedo map has something to recover.
std::optional<fitting::WardParams<double>> MaterialAt(const ObjectCaptureOptions& options, double u, double v) {
  const std::optional<Eigen::Vector3d> normal = NormalAt(options.shape, u, v);
  if (!normal) return std::nullopt;
  fitting::WardParams<double> p = options.material;
  p.n_s = Eigen::Vector3d(normal->x(), -normal->y(), normal->z());
  p.a_d *= 0.8 + 0.2 * std::sin(6 * u + 3 * v);
  return p;
}

// Pixel (i, j)'s RGB radiance under light l (stack frame): the mean over its subpixels.
Eigen::Vector3d PixelRadiance(const ObjectCaptureOptions& options, int i, int j, const Eigen::Vector3d& l) {
  const int n = options.size_px, s = options.subpixels;
  const double radius_px = 0.45 * n;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int b = 0; b < s; ++b) {
    for (int a = 0; a < s; ++a) {
      const double x = i + (a + 0.5) / s, y = j + (b + 0.5) / s;
      const auto p = MaterialAt(options, (x - n / 2.0) / radius_px, -(y - n / 2.0) / radius_px);
      if (!p) continue;
      const Reflectance reflectance(*p, options.beyond);
      for (int c = 0; c < 3; ++c) sum[c] += reflectance.EvaluateCos(l, Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Unit(c));
    }
  }
  return sum / (s * s);
}

}  // namespace

Status ObjectCaptureOptions::Check() const {
  std::vector<std::string> problems;
  if (size_px < 4 || size_px > 4096) problems.push_back("size_px must be in [4, 4096]");
  if (lights < 3 || lights > 1000) problems.push_back("lights must be in [3, 1000]");
  if (!(max_light_deg > 0 && max_light_deg < 90)) problems.push_back("max_light_deg must be in (0, 90)");
  if (!(noise >= 0 && noise < 1)) problems.push_back("noise must be in [0, 1)");
  if (subpixels < 1 || subpixels > 16) problems.push_back("subpixels must be in [1, 16]");
  for (const std::string& p : fitting::CheckWardParams(material)) problems.push_back("material: " + p);
  return ProblemsStatus("ObjectCaptureOptions", problems);
}

ObjectCapture RenderObjectCapture(const ObjectCaptureOptions& options) {
  const int n = options.size_px;
  ObjectCapture capture;
  capture.light_directions = SpiralDirections(options.lights, options.max_light_deg);
  capture.mask = Image(n, n, {"mask"});
  capture.normals = Image(n, n, {"X", "Y", "Z"});
  capture.truth = fitting::MakeSvbrdfImage(n, n, /*with_height=*/false);
  const double radius_px = 0.45 * n;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double u = (i + 0.5 - n / 2.0) / radius_px, v = -(j + 0.5 - n / 2.0) / radius_px;
      const std::optional<fitting::WardParams<double>> p = MaterialAt(options, u, v);
      if (!p) {
        fitting::WardParams<double> none;
        none.n_s = none.a_d = none.a_s = Eigen::Vector3d::Constant(NAN);
        none.sigma_x = none.sigma_y = none.alpha = none.f0 = NAN;
        fitting::SetParams(capture.truth, i, j, none);
        continue;
      }
      capture.mask.at(0, j, i) = 1;
      const Eigen::Vector3d normal(p->n_s.x(), -p->n_s.y(), p->n_s.z());  // the image frame: y up
      for (int c = 0; c < 3; ++c) capture.normals.at(c, j, i) = static_cast<float>(normal[c]);
      fitting::SetParams(capture.truth, i, j, *p);
    }
  }
  std::mt19937_64 random(options.seed);
  std::normal_distribution<double> gauss(0, 1);
  for (const Eigen::Vector3d& light : capture.light_directions) {
    Image image(n, n, {"R", "G", "B"});
    const Eigen::Vector3d l(light.x(), -light.y(), light.z());  // the stack frame
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        if (capture.mask.at(0, j, i) == 0) continue;
        const Eigen::Vector3d radiance = PixelRadiance(options, i, j, l);
        for (int c = 0; c < 3; ++c) image.at(c, j, i) = static_cast<float>(radiance[c] * (1 + options.noise * gauss(random)));
      }
    }
    capture.images.push_back(std::move(image));
  }
  return capture;
}

Status FlashCaptureOptions::Check() const {
  std::vector<std::string> problems;
  if (images < 2 || images > 100) problems.push_back("images must be in [2, 100]");
  if (!(height_cm > 0)) problems.push_back("height_cm must be > 0");
  if (!(ring_cm >= 0)) problems.push_back("ring_cm must be ≥ 0");
  if (!flash_offset_cm.allFinite()) problems.push_back("flash_offset_cm must be finite");
  if (!(power > 0)) problems.push_back("power must be > 0");
  if (!(noise >= 0 && noise < 1)) problems.push_back("noise must be in [0, 1)");
  return ProblemsStatus("FlashCaptureOptions", problems);
}

FlashCapture RenderFlashCapture(const Image& maps, double pixel_mm, const FlashCaptureOptions& options) {
  const int width = maps.width(), height = maps.height();
  FlashCapture capture;
  capture.width_cm = width * pixel_mm / 10;
  std::mt19937_64 random(options.seed);
  std::normal_distribution<double> gauss(0, 1);
  for (int k = 0; k < options.images; ++k) {
    const double angle = 2 * std::numbers::pi * (k - 1) / std::max(1, options.images - 1);
    const Eigen::Vector3d camera_cm =
        k == 0 ? Eigen::Vector3d(0, 0, options.height_cm)
               : Eigen::Vector3d(options.ring_cm * std::cos(angle), options.ring_cm * std::sin(angle), options.height_cm);
    capture.cameras_cm.push_back(camera_cm);
    // The stack frame: mm, y down the image.
    const auto in_stack = [](const Eigen::Vector3d& cm) { return Eigen::Vector3d(10 * cm.x(), -10 * cm.y(), 10 * cm.z()); };
    const Eigen::Vector3d camera = in_stack(camera_cm), light = in_stack(camera_cm + options.flash_offset_cm);
    Image image(width, height, {"R", "G", "B"});
    for (int j = 0; j < height; ++j) {
      for (int i = 0; i < width; ++i) {
        const Eigen::Vector3d p((i + 0.5 - width / 2.0) * pixel_mm, (j + 0.5 - height / 2.0) * pixel_mm, 0);
        const Eigen::Vector3d to_light = light - p;
        const double irradiance = 100 * options.power / to_light.squaredNorm();  // per mm², as loom import has it
        const fitting::WardParams<double> params = fitting::GetParams(maps, i, j);
        const fitting::WardLobe<double> lobe(params);
        const fitting::WardTerms<double> terms = lobe.Terms(to_light.normalized(), (camera - p).normalized());
        for (int c = 0; c < 3; ++c) {
          const double radiance = irradiance * (params.a_d[c] * terms.diffuse + params.a_s[c] * terms.specular) * terms.cos_l;
          image.at(c, j, i) = static_cast<float>(radiance * (1 + options.noise * gauss(random)));
        }
      }
    }
    capture.images.push_back(std::move(image));
  }
  return capture;
}

}  // namespace loom::sim
