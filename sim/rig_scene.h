#pragma once
// A simulated rig's scene from its rig file: the `sample:` (or an object asked for) on the
// turntable of the rig as built. hal/sim's devices share one; training sets render with one
// (apps/train_command.cc) without any device.
//
// `as_built:` says how the simulated hardware differs from its `geometry:`, the nominal
// description loom is given, so that calibration has something to find:
//   as_built:
//     cameras: [{name: cam1, move_mm: [1, -2, 0.5], rotate_deg: [0.3, 0, -0.2], sensitivity_scale: 0.9, vignetting: 0.2}]
//     leds: [{index: 3, intensity_scale: 0.85, move_mm: [5, -3, 2]}]
//     filter_wheels: [{name: wheel0, slot: 2, shift_nm: 8}]
//     projector: {move_mm: [2, 0, -1], rotate_deg: [0.5, 0, 0], focal_scale: 1.03, shift_cx_px: 4}
//     linear_light: {turn_deg: 1.5}
// move_mm shifts a camera's, the projector's or an LED's centre (rig frame); rotate_deg turns a
// camera or the projector about its own x, y, z; the scales multiply the nominal sensitivity and
// intensity (focal_scale the projector's focal length); shift_cx_px moves the projector's
// principal point along its columns; shift_nm moves a filter's band; turn_deg turns the linear
// light's arm about its sweep axis at every carriage position (an offset of its start and end angles).

#include <memory>
#include <string>

#include "core/rig_file.h"
#include "sim/renderer.h"
#include "sim/sample.h"

namespace loom::sim {

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
