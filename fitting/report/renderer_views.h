#pragma once
// Views for checking an exported material in another renderer (web/render-check.mjs renders the
// glTF in three.js): a few of a stack's point-lit observations reduced to what a real-time
// renderer has, an isotropic point light and a distant (orthographic) camera, and loom's own
// rendering of the maps under each through the GD10 model itself. What differs between the two
// is what the glTF export's approximation (gltf_export.h) and the other renderer change.
//
// Both render the maps on a flat quad at z = 0 centred on the sample (as the glTF has it, with
// the heightmap's relief in the normals only) and leave out cast shadows.

#include <filesystem>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/observation_stack.h"

namespace loom::fitting {

struct RendererView {
  int observation = 0;                                 // in the stack
  Eigen::Vector3d light_mm = Eigen::Vector3d::Zero();  // the light's position, sample frame
  double intensity = 0;                                // isotropic radiant intensity
  Eigen::Vector3d view = Eigen::Vector3d::UnitZ();     // unit, towards the camera, sample frame
};

// `count` of the stack's observations lit by one emitter, from the brightest (where highlights
// are) down through the range of mean brightness. The emitter's intensity towards the sample's
// centre becomes the isotropic light's; the camera's direction from the centre, the view.
std::vector<RendererView> ChooseRendererViews(const ObservationStack& stack, int count);

// The maps' RGB radiance (channels R, G, B) under `view`.
Image RenderView(const Image& maps, double pixel_mm, const RendererView& view);

// DIR/views.json and, per view, loom's rendering as DIR/loom-VIEW.f32 (little-endian float32
// RGB, row by row from the maps' first row) and DIR/loom-VIEW.png (white = the rendering's 99th
// percentile, given in views.json so that other renderings can be shown at the same exposure).
// views.json gives each light and view in the sample frame (mm) and in glTF's (metres, +y up:
// the sample's z; −z: the sample's y), and the three.js intensity (candela per the sample's
// units: I · 10⁻⁶, since glTF's metres are 1000 mm).
Status WriteRendererViews(const std::filesystem::path& dir, const Image& maps, double pixel_mm, const ObservationStack& stack,
                          const std::vector<RendererView>& views);

}  // namespace loom::fitting
