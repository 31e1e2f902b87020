#include "sim/fabric.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>

#include "core/check.h"
#include "core/heightfield.h"
#include "core/srgb.h"
#include "fitting/model/svbrdf_maps.h"
#include "sim/internal/grid_check.h"
#include "sim/internal/noise.h"
#include "sim/reflectance.h"

namespace loom::sim {
namespace {

using internal::Hash01;

int Mod(int64_t a, int m) { return static_cast<int>(((a % m) + m) % m); }

bool WarpOnTop(Weave weave, int64_t c, int64_t r) {
  switch (weave) {
    case Weave::kPlain:
      return Mod(c + r, 2) == 0;
    case Weave::kTwill21:
      return Mod(c + r, 3) != 2;
    case Weave::kTwill31:
      return Mod(c + r, 4) != 3;
    case Weave::kSatin5:
      return Mod(2 * c + r, 5) != 0;  // move number 2: no two binding points touch
  }
  return true;
}

constexpr double kThreadWidth = 0.82;  // of the pitch; the rest is the gap between threads
constexpr int kMaxFloat = 6;

// What is visible at one point of the fabric.
struct ThreadSample {
  bool visible = false;  // false: a hole between threads
  bool warp = false;
  int64_t index = 0;  // thread number
  double across = 0;  // −1 .. 1 across the thread
  double along = 0;   // position along the fibre direction, in pitches (for streaks)
  double height = 0;  // relative: 0 .. 1
};

// Rise and fall of a thread over its float (0 at the binding points, 1 mid-float).
double FloatProfile(const FabricDescription& f, bool warp, int64_t c, int64_t r, double frac) {
  const auto on_top = [&](int64_t k) { return warp ? WarpOnTop(f.weave, c, k) : !WarpOnTop(f.weave, k, r); };
  const int64_t here = warp ? r : c;
  int64_t first = here;
  int64_t last = here;
  while (here - first < kMaxFloat && on_top(first - 1)) --first;
  while (last - here < kMaxFloat && on_top(last + 1)) ++last;
  const double s = (static_cast<double>(here - first) + frac) / static_cast<double>(last - first + 1);
  return std::sqrt(std::sin(kPi * s));
}

ThreadSample SampleAt(const FabricDescription& f, double x_mm, double y_mm) {
  // Into fabric coordinates: warp threads run along q, weft along p.
  const double cs = std::cos(f.rotation_rad);
  const double sn = std::sin(f.rotation_rad);
  const double p = (cs * x_mm + sn * y_mm) / f.pitch_mm;
  const double q = (-sn * x_mm + cs * y_mm) / f.pitch_mm;
  const int64_t c = static_cast<int64_t>(std::floor(p));
  const int64_t r = static_cast<int64_t>(std::floor(q));
  const double u = p - c;
  const double v = q - r;
  const double half = kThreadWidth / 2;
  const double across_warp = (u - 0.5) / half;
  const double across_weft = (v - 0.5) / half;
  const bool warp_top = WarpOnTop(f.weave, c, r);
  ThreadSample s;
  const auto take = [&](bool warp, double across, double level, double float_profile) {
    s.visible = true;
    s.warp = warp;
    s.index = warp ? c : r;
    s.across = across;
    s.along = warp ? q : p;
    s.height = level * (0.55 + 0.45 * float_profile) * std::sqrt(std::max(0.0, 1 - across * across));
  };
  if (warp_top && std::abs(across_warp) <= 1) {
    take(true, across_warp, 1.0, FloatProfile(f, true, c, r, v));
  } else if (!warp_top && std::abs(across_weft) <= 1) {
    take(false, across_weft, 1.0, FloatProfile(f, false, c, r, u));
  } else if (std::abs(across_weft) <= 1) {
    take(false, across_weft, 0.35, 0.0);  // the weft seen through the warp's gap
  } else if (std::abs(across_warp) <= 1) {
    take(true, across_warp, 0.35, 0.0);
  }
  return s;
}

double WrapAnisotropyAngle(double alpha) {
  // α and α + π are the same lobe: bring into (−π/2, π/2].
  alpha = std::fmod(alpha, kPi);
  if (alpha <= -kPi / 2) alpha += kPi;
  if (alpha > kPi / 2) alpha -= kPi;
  return alpha;
}

struct PointParams {
  Eigen::Vector3d a_d = Eigen::Vector3d::Zero();
  double a_s = 0;
  double sigma_x = 0.3;
  double sigma_y = 0.3;
  double alpha = 0;
  double height = 0;
};

PointParams ParamsAt(const FabricDescription& f, double x_mm, double y_mm) {
  const ThreadSample s = SampleAt(f, x_mm, y_mm);
  PointParams out;
  if (!s.visible) {  // a hole: the dark, rough backing
    out.a_d = 0.25 * f.warp_colour;
    out.a_s = 0.2 * f.a_s;
    out.sigma_x = out.sigma_y = std::min(1.0, 2 * f.sigma_across);
    return out;
  }
  const uint64_t thread_key = static_cast<uint64_t>(s.index) * 2 + (s.warp ? 1 : 0);
  const double thread_shade = 1 + 0.16 * (Hash01(f.seed, thread_key, 1) - 0.5);
  // Fibre streaks: slow along the fibre, fast across it.
  const double streak = 1 + 0.12 * (internal::ValueNoise(f.seed + 7, s.along * 3.0, s.across * 4.0 + s.index * 17.0) - 0.5);
  const Eigen::Vector3d colour = s.warp ? f.warp_colour : f.weft_colour;
  out.a_d = (colour * thread_shade * streak).cwiseMin(1.0);
  out.a_s = f.a_s * (1 + 0.2 * (Hash01(f.seed, thread_key, 2) - 0.5));
  const double spread = 1 + 0.2 * (Hash01(f.seed, thread_key, 3) - 0.5);
  out.sigma_x = std::clamp(f.sigma_along * spread, 1e-3, 1.0);
  out.sigma_y = std::clamp(f.sigma_across * spread, 1e-3, 1.0);
  // Warp along q, weft along p (fabric frame); fibres twisted by ±twist (S and Z yarns).
  const double thread_angle = f.rotation_rad + (s.warp ? kPi / 2 : 0.0);
  out.alpha = WrapAnisotropyAngle(thread_angle + (s.warp ? f.twist_rad : -f.twist_rad));
  out.height = s.height * f.relief_mm;
  return out;
}

Eigen::Vector3d HsvToLinearRgb(double h, double s, double v) {
  const double c = v * s;
  const double hp = h * 6;
  const double x = c * (1 - std::abs(std::fmod(hp, 2.0) - 1));
  // The hue's sextant picks which channel gets c, x and 0.
  const std::array<Eigen::Vector3d, 6> sextants = {Eigen::Vector3d(c, x, 0), Eigen::Vector3d(x, c, 0), Eigen::Vector3d(0, c, x),
                                                   Eigen::Vector3d(0, x, c), Eigen::Vector3d(x, 0, c), Eigen::Vector3d(c, 0, x)};
  Eigen::Vector3d rgb = sextants[std::clamp(static_cast<int>(hp), 0, 5)];
  rgb.array() += v - c;
  // HSV values are display (sRGB-encoded) values: decode to linear.
  for (int i = 0; i < 3; ++i) rgb[i] = SrgbDecode(rgb[i]);
  return rgb;
}

}  // namespace

std::string_view WeaveName(Weave weave) {
  switch (weave) {
    case Weave::kPlain:
      return "plain";
    case Weave::kTwill21:
      return "twill 2/1";
    case Weave::kTwill31:
      return "twill 3/1";
    case Weave::kSatin5:
      return "satin 5";
  }
  return "unknown";
}

FabricDescription RandomFabric(uint64_t seed) {
  internal::Rng rng(seed);
  FabricDescription f;
  f.seed = seed;
  f.weave = static_cast<Weave>(static_cast<int>(rng.Uniform() * 4) % 4);
  f.pitch_mm = 0.35 + 1.15 * rng.Uniform();
  f.rotation_rad = kPi * rng.Uniform();
  const double hue = rng.Uniform();
  f.warp_colour = HsvToLinearRgb(hue, 0.9 * rng.Uniform(), 0.1 + 0.8 * rng.Uniform());
  f.weft_colour =
      rng.Uniform() < 0.5 ? f.warp_colour : HsvToLinearRgb(rng.Uniform(), 0.9 * rng.Uniform(), 0.1 + 0.8 * rng.Uniform());
  f.a_s = 0.02 + 0.43 * rng.Uniform();
  // Keep a_d + a_s ≤ 1 (with room for the per-thread variation).
  const double room = (1 - f.a_s) / 1.2;
  f.warp_colour = f.warp_colour.cwiseMin(room);
  f.weft_colour = f.weft_colour.cwiseMin(room);
  f.sigma_along = std::exp(std::log(0.02) + (std::log(0.3) - std::log(0.02)) * rng.Uniform());
  f.sigma_across = std::min(1.0 / 1.1, f.sigma_along * (1.5 + 6.5 * rng.Uniform()));
  f.f0 = 0.02 + 0.98 * rng.Uniform();
  f.relief_mm = 0.05 + 0.25 * rng.Uniform();
  f.twist_rad = DegToRad(30) * rng.Uniform();
  return f;
}

Status FabricOptions::Check() const {
  std::vector<std::string> problems;
  internal::AddGridProblems(width_px, height_px, pixel_mm, /*zero_is_default=*/false, problems);
  if (!(geometric_blur_mm >= 0 && geometric_blur_mm <= 1000)) problems.push_back("geometric_blur_mm must be in [0, 1000]");
  if (supersampling < 1 || supersampling > 16) problems.push_back("supersampling must be in [1, 16]");
  return ProblemsStatus("FabricOptions", problems);
}

Material MakeFabric(const FabricDescription& f, const FabricOptions& options) {
  const Status checked = options.Check();
  LOOM_CHECK(checked.ok()) << checked.ToString();
  const int w = options.width_px;
  const int h = options.height_px;
  const double px = options.pixel_mm;
  const int ss = options.supersampling;
  Material material;
  material.name = "fabric " + std::string(WeaveName(f.weave));
  material.pixel_mm = px;
  material.maps = fitting::MakeSvbrdfImage(w, h, /*with_height=*/true);
  std::vector<double> height(static_cast<size_t>(w) * h);
  std::vector<PointParams> centre(height.size());
  std::vector<Eigen::Vector3d> a_d(height.size(), Eigen::Vector3d::Zero());
  std::vector<double> a_s(height.size(), 0.0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      // Sample-frame coordinates (mm) of the pixel centre; the sample centre is the grid centre.
      const double cx = (x + 0.5 - w / 2.0) * px;
      const double cy = (y + 0.5 - h / 2.0) * px;
      centre[i] = ParamsAt(f, cx, cy);
      height[i] = centre[i].height;
      // Albedos are averaged over sub-pixels (thread edges); angles are not averageable.
      for (int sy = 0; sy < ss; ++sy) {
        for (int sx = 0; sx < ss; ++sx) {
          const PointParams sub = ParamsAt(f, cx + ((sx + 0.5) / ss - 0.5) * px, cy + ((sy + 0.5) / ss - 0.5) * px);
          a_d[i] += sub.a_d / (ss * ss);
          a_s[i] += sub.a_s / (ss * ss);
        }
      }
    }
  }
  const std::vector<Eigen::Vector3d> geometric_normals = GeometricNormals(height, w, h, px, options.geometric_blur_mm);
  const int height_channel = *material.maps.ChannelIndex(fitting::kHeightChannel);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const Eigen::Vector3d& geometric = geometric_normals[i];
      const Eigen::Vector3d fine = HeightfieldNormal(height, w, h, x, y, px);
      const Eigen::Matrix3d world_from_local = WorldFromLocal(geometric, Eigen::Vector3d::UnitX());
      fitting::WardParams<double> p;
      p.n_s = (world_from_local.transpose() * fine).normalized();
      p.a_d = a_d[i];
      p.a_s = Eigen::Vector3d::Constant(a_s[i]);
      p.sigma_x = centre[i].sigma_x;
      p.sigma_y = centre[i].sigma_y;
      p.alpha = centre[i].alpha;
      p.f0 = f.f0;
      fitting::SetParams(material.maps, x, y, p);
      material.maps.at(height_channel, y, x) = static_cast<float>(height[i]);
    }
  }
  material.provenance = {{"loom.generator", std::string("sim::MakeFabric")},
                         {"loom.seed", static_cast<int>(f.seed & 0x7FFFFFFF)},
                         {"loom.weave", std::string(WeaveName(f.weave))},
                         {"loom.pitch_mm", f.pitch_mm},
                         {"loom.rotation_rad", f.rotation_rad},
                         {"loom.relief_mm", f.relief_mm},
                         {"loom.geometric_blur_mm", options.geometric_blur_mm}};
  return material;
}

Material GenerateFabric(uint64_t seed, const FabricOptions& options) { return MakeFabric(RandomFabric(seed), options); }

FabricBeyond RandomFabricBeyond(uint64_t seed) {
  // A stream apart from RandomFabric's (whose draws stay as they were for every seed).
  internal::Rng rng(seed ^ 0x6265796f6e64ULL);
  FabricBeyond b;
  if (rng.Uniform() < 0.5) {
    const Eigen::Vector3d tint = HsvToLinearRgb(rng.Uniform(), 0.2 + 0.5 * rng.Uniform(), 1.0);
    b.specular_tint = tint / tint.maxCoeff();
  }
  if (rng.Uniform() < 2.0 / 3) {
    b.coat = 0.03 + 0.12 * rng.Uniform();
    b.coat_roughness = std::exp(std::log(0.05) + (std::log(0.5) - std::log(0.05)) * rng.Uniform());
  }
  if (rng.Uniform() < 2.0 / 3) b.fibre_masking = 0.2 + 0.5 * rng.Uniform();
  if (rng.Uniform() < 2.0 / 3) b.meso_deg = 2 + 8 * rng.Uniform();
  return b;
}

Material MakeOutOfModelFabric(const FabricDescription& fabric, const FabricBeyond& b, const FabricOptions& options) {
  Material material = MakeFabric(fabric, options);
  material.name += " (out of model)";
  const BeyondLayout layout = AddBeyondChannels(material.maps);
  BeyondGd10 beyond;
  beyond.coat = Eigen::Vector3d::Constant(b.coat);
  beyond.coat_roughness = b.coat_roughness;
  beyond.fibre_masking = b.fibre_masking;
  beyond.meso_deg = b.meso_deg;
  for (int y = 0; y < material.height(); ++y) {
    for (int x = 0; x < material.width(); ++x) {
      fitting::WardParams<double> p = fitting::GetParams(material.maps, x, y);
      p.a_d *= 1 - b.coat;
      p.a_s = p.a_s.cwiseProduct(b.specular_tint);
      fitting::SetParams(material.maps, x, y, p);
      SetBeyond(material.maps, layout, x, y, beyond);
    }
  }
  material.provenance["loom.generator"] = std::string("sim::MakeOutOfModelFabric");
  material.provenance["loom.beyond.specular_tint"] =
      std::to_string(b.specular_tint.x()) + " " + std::to_string(b.specular_tint.y()) + " " + std::to_string(b.specular_tint.z());
  material.provenance["loom.beyond.coat"] = b.coat;
  material.provenance["loom.beyond.coat_roughness"] = b.coat_roughness;
  material.provenance["loom.beyond.fibre_masking"] = b.fibre_masking;
  material.provenance["loom.beyond.meso_deg"] = b.meso_deg;
  return material;
}

Material GenerateOutOfModelFabric(uint64_t seed, const FabricOptions& options) {
  return MakeOutOfModelFabric(RandomFabric(seed), RandomFabricBeyond(seed), options);
}

}  // namespace loom::sim
