#pragma once
// What lies on the simulated rig's turntable: a material chosen by kind (and seed), as the
// `sample:` section of a sim rig YAML or `loom sim material` ask for it.
//
//   sample: {kind: fabric, seed: 1, size_px: 256, pixel_mm: 0.1}
//
// kinds: fabric (procedural, by seed), fabric-out-of-model (the same fabric with what GD10 cannot
// represent: fabric.h's GenerateOutOfModelFabric), white-tile (and white-tile-on-spacer, raised by the rig's
// white_reference spacer_mm), chessboard, colour-chart, and target and chrome-sphere (the rig's
// calibration target and light probe, their sizes their own).

#include <cstdint>
#include <string>

#include "core/config.h"
#include "core/rig_model.h"
#include "sim/material.h"

namespace loom::sim {

struct SampleSpec {
  std::string kind = "fabric";
  uint64_t seed = 0;
  int size_px = 256;
  double pixel_mm = 0.1;
  std::optional<CalibrationTargetModel> target;  // the rig's, for kind "target"
  ColourChartModel chart;                        // the rig's, for kind "colour-chart"
  WhiteReferenceModel white;                     // the rig's, for kinds "white-tile", "white-tile-on-spacer"
  LightProbeModel probe;                         // the rig's, for kind "chrome-sphere"
  // size_px in [8, kMaxSampleSide], pixel_mm in [0.001, 10] (NaN fails): every problem, naming
  // the field.
  Status Check() const;
};

// The largest sample side: 4096² maps of 14 float channels are ~1 GB.
inline constexpr int kMaxSampleSide = 4096;

SampleSpec ReadSampleSpec(const ConfigNode& node);
Result<Material> MakeSample(const SampleSpec& spec);

}  // namespace loom::sim
