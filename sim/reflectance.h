#pragma once
// The simulator's reflectance at one map pixel: the GD10 lobe of its parameters
// (fitting/model/ward_gd10.h) and, where a material carries them, effects that real materials
// show and GD10 cannot represent, so that a fitted GD10 does not re-render every simulated scan
// exactly, as it never does a real one (issue #22). Each effect is an optional channel of
// Material::maps; where it is absent or 0 the pixel is GD10 and nothing else.
//
// | channel               | effect                                                                 |
// |-----------------------|------------------------------------------------------------------------|
// | beyond.coat.R/G/B     | a second, isotropic lobe: GGX (Trowbridge–Reitz) D, Smith's G, the     |
// |                       | pixel's Schlick F; f += coat · F D G / (4 (n·l)(n·v)), a coloured albedo |
// | beyond.coat_roughness | the coat's GGX α                                                       |
// | beyond.fibre_masking  | parallel fibres along the anisotropy tangent t shadow and mask:        |
// |                       | f ×= G1(l) G1(v), G1(w) = 1 − m (1 − cos θ⊥), θ⊥ the angle of w from    |
// |                       | n_s in the plane across the fibres (none along them)                    |
// | beyond.meso_deg       | normals vary inside the pixel's footprint: the reflectance averages    |
// |                       | 4 copies of the pixel's, n_s tilted by this angle towards ±t and ±b    |
//
// The same channels in every material that has any (MakeBeyondChannels); the GD10 channels are
// what fitting compares against (they are the material's nominal parameters, not the best GD10
// fit of the pixel).
// Thread-safety: immutable; Evaluate may run on many threads.

#include <array>
#include <optional>

#include "core/geometry.h"
#include "core/image.h"
#include "fitting/model/ward_gd10.h"

namespace loom::sim {

inline constexpr std::array<const char*, 6> kBeyondChannels = {
    "beyond.coat.R", "beyond.coat.G", "beyond.coat.B", "beyond.coat_roughness", "beyond.fibre_masking", "beyond.meso_deg"};

struct BeyondGd10 {
  Eigen::Vector3d coat = Eigen::Vector3d::Zero();
  double coat_roughness = 0.2;  // GGX α
  double fibre_masking = 0;     // m ∈ [0, 1]
  double meso_deg = 0;

  bool any() const { return coat.any() || fibre_masking > 0 || meso_deg > 0; }
};

// Where a map image keeps kBeyondChannels (nothing: it has none of them).
struct BeyondLayout {
  std::array<int, kBeyondChannels.size()> channel{};
};
// The layout of `maps`: nothing when none of the channels is there, an error naming the first
// missing one when only some are.
Result<std::optional<BeyondLayout>> FindBeyondChannels(const Image& maps);
BeyondGd10 GetBeyond(const Image& maps, const BeyondLayout& layout, int x, int y);
// Adds the channels (zero-filled) to `maps`, returns their layout.
BeyondLayout AddBeyondChannels(Image& maps);
void SetBeyond(Image& maps, const BeyondLayout& layout, int x, int y, const BeyondGd10& beyond);

class Reflectance {
 public:
  Reflectance(const fitting::WardParams<double>& params, const BeyondGd10& beyond = {});

  // f_r(l, v) · (n_s·l) seen through colour weights w (w·a for each albedo a): the radiance per
  // unit irradiance. l, v unit, in the local geometric frame; 0 where GD10's zero conditions hold
  // (for each of the mesostructure's normals).
  double EvaluateCos(const Eigen::Vector3d& l, const Eigen::Vector3d& v, const Eigen::Vector3d& weights) const;

 private:
  double FacetCos(const fitting::WardLobe<double>& lobe, const Eigen::Vector3d& l, const Eigen::Vector3d& v,
                  const Eigen::Vector3d& weights) const;
  // EvaluateCos of a Lambertian pixel: GD10's zero conditions, then a_d / π · cos θ_l.
  double DiffuseCos(const Eigen::Vector3d& l, const Eigen::Vector3d& v, const Eigen::Vector3d& weights) const;

  BeyondGd10 beyond_;
  fitting::WardParams<double> params_;
  // The pixel's own lobe, or with mesostructure its 4 tilted copies (a renderer builds one
  // Reflectance per shaded point: without mesostructure nothing is allocated). None for a
  // Lambertian pixel (no specular albedo, nothing beyond GD10): the calibration objects and the
  // holder, most of a calibration scan's points, whose lobe frame and exp() were a third of
  // rendering it (perf) and multiplied a zero albedo.
  std::optional<fitting::WardLobe<double>> lobe_;
  std::vector<fitting::WardLobe<double>> facets_;
};

}  // namespace loom::sim
