#pragma once
// The fast path: the ideal observation stack, rendered directly in the top-view reference frame
// (the sample frame at turntable angle 0, seen from above): for every stack pixel, the surface
// point's position and geometric normal, and for every observation the radiance leaving that
// point towards the observation's camera under its lights — shadowing included; NaN where the
// camera does not see the point (occluded by the relief). This is the ground truth that
// reconstruction's calibrated stacks approximate, and the CNN's training data.
//
// Channels: pos.X pos.Y pos.Z (mm, sample frame), normal.X normal.Y normal.Z (geometric), then
// obs0000, obs0001, ... (radiance units). The observations are described in the EXR attribute
// `loom.observations` (one line each: camera, turntable angle, LEDs and currents, filter).

#include <string>
#include <vector>

#include "core/exr_io.h"
#include "sim/renderer.h"

namespace loom::sim {

struct Observation {
  int camera = 0;           // index into RigModel::cameras
  SceneState state;         // lights, filter slots, turntable angle
};

struct StackOptions {
  int width_px = 0;         // 0: the material's grid
  int height_px = 0;
  double pixel_mm = 0;      // 0: the material's pixel size
  bool shadows = true;
  int threads = 0;          // 0: one per core
};

// Every camera × every LED at 1000 mA × each turntable angle, then every filtered LED through
// each filter for every camera at angle 0: a plan-free default until acquisition's plans exist.
std::vector<Observation> DefaultObservations(const RigModel& rig, const std::vector<double>& turntable_deg);

// One line per observation, for the `loom.observations` attribute.
std::string DescribeObservations(const RigModel& rig, const std::vector<Observation>& observations);

Image RenderStack(const Scene& scene, const std::vector<Observation>& observations, const StackOptions& options);

// Writes a stack with its observations described, uncompressed (noise does not compress).
Status WriteStack(const std::filesystem::path& path, const Image& stack, const RigModel& rig,
                  const std::vector<Observation>& observations, double pixel_mm);

}  // namespace loom::sim
