#pragma once
// Procedural woven fabrics, deterministic by seed: the simulator's stand-in for the textiles the
// paper scans. A fabric is a weave (plain, twill, satin) of warp threads (along the sample's y
// before rotation) and weft threads (along x); on top at each crossing is one of them. Every
// visible point belongs to a thread, whose direction sets the anisotropy angle (fibres twisted
// by the yarn's twist), whose colour sets a_d, and whose cross-section and float set the height.
//
// | choice (per seed)   | range                                   | why                           |
// |---------------------|-----------------------------------------|-------------------------------|
// | weave               | plain, twill 2/1, twill 3/1, satin 5    | the common textile structures |
// | thread pitch        | 0.35 .. 1.5 mm                          | ~3..15 map pixels at 0.1 mm   |
// | rotation            | [0, π)                                  | threads at any angle          |
// | warp / weft colour  | random HSV, weft = warp half the time   | per-thread colours            |
// | a_s                 | 0.02 .. 0.45, a_d scaled so a_d + a_s ≤ 1 | energy conservation         |
// | σ along the fibre   | 0.02 .. 0.3 (log-uniform)               | narrow fibre highlights       |
// | σ across the fibre  | σ_along × 1.5 .. 8, ≤ 1                 | σx ≠ σy                       |
// | F0                  | 0.02 .. 1                               | the model's full range        |
// | relief              | 0.05 .. 0.3 mm                          | thread height                 |
// | twist               | 0 .. 30°                                | fibre angle vs thread axis    |
//
// Shading normals are those of the fine heightmap expressed in the local geometric frame of the
// heightmap blurred to `geometric_blur_mm` (what structured light resolves): the pipeline's
// geometric normal comes from a coarse heightmap, the fine relief lives in n_s.

#include <cstdint>
#include <string>

#include "core/geometry.h"
#include "core/status.h"
#include "sim/material.h"

namespace loom::sim {

enum class Weave { kPlain, kTwill21, kTwill31, kSatin5 };
std::string_view WeaveName(Weave weave);

struct FabricDescription {
  Weave weave = Weave::kPlain;
  double pitch_mm = 0.8;
  double rotation_rad = 0.0;
  Eigen::Vector3d warp_colour{0.5, 0.1, 0.1};  // linear sRGB diffuse albedo
  Eigen::Vector3d weft_colour{0.5, 0.1, 0.1};
  double a_s = 0.1;
  double sigma_along = 0.1;
  double sigma_across = 0.4;
  double f0 = 0.04;
  double relief_mm = 0.15;
  double twist_rad = 0.2;
  uint64_t seed = 0;  // also seeds the per-thread variation
};

struct FabricOptions {
  int width_px = 256;
  int height_px = 256;
  double pixel_mm = 0.1;
  double geometric_blur_mm = 1.0;  // scale of the geometric normal (structured light)
  int supersampling = 3;           // per axis, for the parameter maps of thread edges
  Status Check() const;            // every problem, naming the field (the makers throw on one)
};

// The choices a seed makes (the table above).
FabricDescription RandomFabric(uint64_t seed);
// Maps for a description.
Material MakeFabric(const FabricDescription& fabric, const FabricOptions& options);
// RandomFabric + MakeFabric.
Material GenerateFabric(uint64_t seed, const FabricOptions& options);

// Out-of-model fabrics: what real fabrics show and GD10 cannot represent (sim/reflectance.h),
// on top of a fabric's GD10 maps, and a coloured specular albedo (GD10 has it, the procedural
// fabrics do not). Each effect is on for a share of the seeds:
//
// | choice (per seed)  | share | range                          | what it stands for             |
// |--------------------|-------|--------------------------------|--------------------------------|
// | specular tint      | 1/2   | hue any, saturation 0.2 .. 0.7 | metallic and dyed-fibre sheen  |
// | coat (GGX lobe)    | 2/3   | albedo 0.03 .. 0.15, grey      | a second lobe: finish, sizing  |
// | coat roughness     |       | GGX α 0.05 .. 0.5 (log-uniform)| sharp gloss to broad sheen     |
// | fibre masking      | 2/3   | 0.2 .. 0.7                     | fibres shadowing each other    |
// | mesostructure      | 2/3   | 2 .. 10°                       | fibres finer than a pixel      |
//
// a_d is scaled by (1 − coat) so that the energy stays bounded. The GD10 channels stay the
// fabric's nominal parameters (what the CNN is trained towards); they are not the best GD10 fit.
struct FabricBeyond {
  Eigen::Vector3d specular_tint = Eigen::Vector3d::Ones();  // multiplies a_s; max component 1
  double coat = 0;
  double coat_roughness = 0.2;
  double fibre_masking = 0;
  double meso_deg = 0;
};

// A seed's out-of-model choices, from a random stream of their own: the fabric under them is
// RandomFabric(seed)'s.
FabricBeyond RandomFabricBeyond(uint64_t seed);
Material MakeOutOfModelFabric(const FabricDescription& fabric, const FabricBeyond& beyond, const FabricOptions& options);
// RandomFabric + RandomFabricBeyond + MakeOutOfModelFabric.
Material GenerateOutOfModelFabric(uint64_t seed, const FabricOptions& options);

}  // namespace loom::sim
