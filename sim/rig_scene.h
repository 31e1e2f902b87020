#pragma once
// A simulated rig's scene from its rig file: the `sample:` (or an object asked for) on the
// turntable of the rig as built. hal/sim's devices share one; training sets render with one
// (apps/train_command.cc) without any device.
//
// `as_built:` says how the simulated hardware differs from its `geometry:`, the nominal
// description loom is given, so that calibration has something to find:
//   as_built:
//     cameras: [{name: cam1, move_mm: [1, -2, 0.5], rotate_deg: [0.3, 0, -0.2], sensitivity_scale: 0.9, vignetting: 0.2,
//                vignetting_centre_px: [30, -20], vignetting_quartic: 0.3}]
//     leds: [{index: 3, intensity_scale: 0.85, move_mm: [5, -3, 2]}]
//     filter_wheels: [{name: wheel0, slot: 2, shift_nm: 8}]
//     projector: {move_mm: [2, 0, -1], rotate_deg: [0.5, 0, 0], focal_scale: 1.03, shift_cx_px: 4}
//     linear_light: {turn_deg: 1.5, profile: [0.9, 1, 1.1]}
// move_mm shifts a camera's, the projector's or an LED's centre (rig frame); rotate_deg turns a
// camera or the projector about its own x, y, z; the scales multiply the nominal sensitivity and
// intensity (focal_scale the projector's focal length); vignetting_centre_px moves the lens's
// optical centre off the image's and vignetting_quartic adds − w q² to its falloff, both out of
// the reach of loom's quadratic vignetting model (a per-pixel flat field is what holds them); shift_cx_px moves the projector's
// principal point along its columns; shift_nm moves a filter's band; turn_deg turns the linear
// light's arm about its sweep axis at every carriage position (an offset of its start and end angles);
// profile is the strip's output along its length as built (core/rig_model.h's LinearLightModel::profile).

#include <memory>
#include <string>

#include "core/rig_file.h"
#include "sim/renderer.h"
#include "sim/sample.h"

namespace loom::sim {

// A lens whose vignetting loom's quadratic model cannot hold: 1 − v q' − w q'², q' the squared
// distance from an optical centre `centre_px` off the image centre, over the corner's (v the
// camera's vignetting, w `quartic`); as a flat field over the camera's quadratic model
// (SensorModel::flat_field). What as_built's vignetting_centre_px and vignetting_quartic build.
std::shared_ptr<const Image> NonQuadraticVignetting(const CameraModel& camera, const Eigen::Vector2d& centre_px, double quartic);

// The rig `model` as built: `model` with the file's `as_built:` differences.
RigModel AsBuilt(const RigFile& file, RigModel model);

struct RigScene {
  std::shared_ptr<Scene> scene;
  SampleSpec sample;  // what the rig's "sample" is
};

// The scene of `file`'s simulated rig (`model`: its geometry). `object` replaces the `sample:`
// ("fabric:SEED", "white-tile", "chessboard", "colour-chart"); empty keeps it.
Result<RigScene> MakeRigScene(const RigFile& file, const RigModel& model, const std::string& object);

}  // namespace loom::sim
