#pragma once
// SVBRDF maps as a MaterialX document for studio pipelines (Houdini, Maya, Blender, USD, three.js's
// MaterialXLoader): DIR/material.mtlx, a standard_surface material whose inputs read PNG textures
// written beside it. Autodesk Standard Surface rather than OpenPBR Surface: the renderers that read
// MaterialX today all implement standard_surface, OpenPBR only some of them; the two translate
// into each other with MaterialX's own translation graphs.
//
// Standard Surface is not GD10-Ward, so the export approximates, as the glTF export does
// (gltf_export.h), per pixel:
//   - base colour = a_d, base 1, diffuse_roughness 0 (Lambert), metalness 0. The base layer sits
//     under the specular one, darkened where it reflects; loom's model adds the two lobes.
//   - specular_color = a_s · F0 / F0_max with specular 1 and specular_IOR chosen so that the
//     dielectric's normal-incidence reflectance is F0_max, the largest a_s · F0 of the maps.
//     At grazing angles its Fresnel rises to 1, loom's Schlick term to a_s.
//   - roughness and anisotropy: GGX α = √2 σ per axis (internal/texture_frame.h); Standard
//     Surface's α_x = r² / √(1 − a), α_y = r² √(1 − a), so r = (α_t α_b)^¼ and a = 1 − α_b / α_t
//     (at most 0.98, its own clamp); specular_rotation turns the tangent onto the wider axis, as a
//     fraction of a full turn in [0, 0.5) (a lobe is the same turned by half a turn), clockwise
//     about the normal (from the image's columns towards up the image), as MaterialX's rotate3d
//     turns in its own shaders (mtlx_export.cc says why). Where the wider axis flips across 0.5
//     between texels, filtering blends two rotations.
//   - normal: n_s in tangent space through a normalmap node, (n + 1) / 2 as glTF's normal textures
//     (x along the image's columns, y up its rows), tilted by the heightmap's geometric normal
//     when the maps have `height`.
// Units and frame: the textures are the maps texel for texel; u runs along the image's columns
// and v up its rows, and the document's doc string gives the sample's size in mm. Pixels the fit
// skipped (NaN) are black. No C++ MaterialX library is packaged in Debian 12, so the XML is
// written here and checked by the MaterialX library itself (its WebAssembly build:
// web/validate-mtlx.mjs; web/tests/mtlx_validation_test.sh), which also generates the shader
// that renders it beside loom's rendering (web/render-mtlx.mjs).

#include <filesystem>

#include "core/image.h"
#include "core/status.h"

namespace loom::fitting {

// Standard Surface's specular_roughness and specular_anisotropy for one pixel's Ward lobe (above).
struct StandardSurfaceRoughness {
  double roughness = 1;
  double anisotropy = 0;
};
StandardSurfaceRoughness StandardSurfaceRoughnessOf(double sigma_x, double sigma_y);

// `maps`: fitting/model/svbrdf_maps.h's layout; `pixel_mm`: the grid. `dir` (new or empty)
// appears complete or not at all (core/output_directory.h).
Status WriteMaterialX(const Image& maps, double pixel_mm, const std::filesystem::path& dir);

}  // namespace loom::fitting
