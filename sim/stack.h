#pragma once
// The fast path: the ideal observation stack (core/observation_stack.h), rendered directly in
// the top-view reference frame: for every stack pixel, the surface point's position and
// geometric normal, and for every observation the radiance leaving that point towards the
// observation's camera under its lights — shadowing included; NaN where the camera does not see
// the point (occluded by the relief). This is the ground truth that reconstruction's calibrated
// stacks approximate, and the CNN's training data. Its observation table holds the true rig
// geometry and light model, so the model reproduces every value exactly (tested in fitting).

#include <string>
#include <vector>

#include "core/observation_stack.h"
#include "sim/renderer.h"

namespace loom::sim {

struct Observation {
  int camera = 0;    // index into RigModel::cameras
  SceneState state;  // lights, filter slots, turntable angle
};

struct StackOptions {
  int width_px = 0;  // 0: the material's grid
  int height_px = 0;
  double pixel_mm = 0;  // 0: the material's pixel size
  bool shadows = true;
  int threads = 0;       // 0: one per core
  Status Check() const;  // every problem, naming the field (RenderStack throws on one)
};

// Every camera × every LED at 1000 mA × each turntable angle, then every filtered LED through
// each filter for every camera at angle 0: a plan-free default until acquisition's plans exist.
std::vector<Observation> DefaultObservations(const RigModel& rig, const std::vector<double>& turntable_deg);

// The table entry of an observation (core/rig_observation.h: DescribeRigObservation); an
// observation it cannot describe (lights of different colour at once) is CHECKed.
StackObservation DescribeObservation(const RigModel& rig, const Observation& observation);

ObservationStack RenderStack(const Scene& scene, const std::vector<Observation>& observations, const StackOptions& options);

// The ground truth on the grid RenderStack renders with `options`: the material's maps at each
// stack pixel's centre (nearest map pixel; all zero where the grid leaves the material), so a
// fit of the stack compares pixel for pixel. Same channels as the material.
Material TruthOnStackGrid(const Scene& scene, const StackOptions& options);

}  // namespace loom::sim
