#pragma once
// Renderer-ready export: SVBRDF maps as a glTF 2.0 material on a quad the size of the sample,
// with KHR_materials_anisotropy and KHR_materials_specular (three.js, Blender 4, Babylon.js and
// the Khronos sample viewer read them). glTF's model is not GD10-Ward, so the export
// approximates; per pixel:
//   - base colour = a_d (metallic 0). glTF darkens the diffuse where the specular reflects
//     (1 − F); loom's model adds the two lobes. Visible only on strongly specular pixels.
//   - specular F0 colour = a_s · F0 (loom's Fresnel multiplies the specular albedo), carried by
//     specularColorFactor × specularColorTexture over the dielectric 0.04. At grazing angles
//     glTF's Schlick term rises to 1, loom's to a_s.
//   - GGX roughness α = √2 · σ, clamped to 1: the Ward lobe is a Beckmann distribution of slope
//     RMS σ, and √2 matches the two distributions' curvature at the peak. glTF roughness = √α.
//   - anisotropy: along the axis of the larger σ (α, or α + 90° when σy > σx), strength
//     s = √((α_t − α_b)/(1 − α_b)) so that glTF's α_t = mix(α_b, 1, s²) gives the larger
//     roughness and α_b the smaller one.
//     KHR_materials_anisotropy's lobe keeps its tangent and bitangent in the quad's plane (so
//     three.js and Khronos' sample viewer implement it), not perpendicular to a normal-mapped
//     shading normal: where shading normals tilt by more than the lobe is wide, the highlight
//     sits where the flat surface would have it. On a fabric whose threads tilt 38°, three.js
//     then rendered near-mirror views 7× too bright (web/render-check.mjs). Such maps are
//     exported isotropic (GltfAnisotropy::kAuto): roughness from α = √(α_t α_b), no
//     anisotropy extension; the glTF's material extras say which was chosen and why.
//   - normal map: n_s, tilted by the heightmap's geometric normal when the maps have `height`
//     (the quad itself is flat: the mesoscale relief lives in the normals only).
// Files: DIR/material.gltf, material.bin (the quad), base_color.png, specular_color.png,
// metallic_roughness.png, normal.png and, when anisotropic, anisotropy.png. The textures are the maps texel for texel,
// padded (edge texels repeated) to powers of two, which WebGL 1 needs for mipmaps; the quad's
// texture coordinates span the maps' part. Khronos' glTF Validator reports no issue on them
// (web/tests/gltf_validation_test.sh).

#include <filesystem>
#include <string>

#include "core/image.h"

namespace loom::fitting {

enum class GltfAnisotropy {
  kAuto,  // anisotropic unless the shading normals tilt more than the lobes are wide (above)
  kOn,    // KHR_materials_anisotropy whatever the normals
  kOff,   // isotropic GGX, α = √(α_t α_b)
};

// Whether the export of `maps` uses KHR_materials_anisotropy, and why, for people.
struct GltfAnisotropyChoice {
  bool anisotropic = true;
  std::string reason;
};
GltfAnisotropyChoice ChooseGltfAnisotropy(const Image& maps, double pixel_mm, GltfAnisotropy mode);

// `maps`: fitting/model/svbrdf_maps.h's layout; `pixel_mm`: the grid (the quad is width · pixel_mm wide).
// `dir` (new or empty) appears complete or not at all (core/output_directory.h). Returns the
// anisotropy choice made.
Result<GltfAnisotropyChoice> WriteGltf(const Image& maps, double pixel_mm, const std::filesystem::path& dir,
                                       GltfAnisotropy anisotropy = GltfAnisotropy::kAuto);

// The GGX roughness that stands for one pixel's Ward lobe (the mapping above); the anisotropy
// runs along t (σx's axis) or, when σy is the larger, along b.
struct GltfRoughness {
  double roughness = 1;            // glTF roughness: √α_b
  double anisotropy_strength = 0;  // s ∈ [0, 1]
  bool along_b = false;
};
GltfRoughness GltfRoughnessOf(double sigma_x, double sigma_y);

}  // namespace loom::fitting
