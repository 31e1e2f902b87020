#pragma once
// A CNN's training set rendered on the simulated rig: procedural fabrics (seeds first_seed,
// first_seed + 1, …), each rendered with the fast path (stack.h) into DIR/fabric-SEED.stack.exr
// with its ground truth on the stack's grid in DIR/fabric-SEED.truth.exr; an out_of_model_share
// of the seeds, spread evenly, are fabric.h's out-of-model fabrics (fabric-SEED-out-of-model.*),
// and a scan_like_share of them are degraded as a scan's reconstruction would be
// (scan_emulation.h; NAME-scan-like.*: the truth stays the sharp one).
// Pairs already in DIR are kept, not rendered again, so a set is built once and grown later.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "sim/renderer.h"
#include "sim/scan_emulation.h"
#include "sim/stack.h"

namespace loom::sim {

struct TrainingSetSpec {
  int materials = 24;
  int size_px = 64;
  uint64_t first_seed = 1000;
  double out_of_model_share = 0;
  double scan_like_share = 0;
  ScanEmulation scan_emulation;   // needed when scan_like_share > 0
  int threads = 0;                // materials rendered at once; 0: one per core (the files are the same)
  Status Check() const;           // every problem, naming the field
  nlohmann::json ToJson() const;  // every field, the emulation's when it is used
};

// Called after each material, by one rendering thread at a time (materials are rendered in
// parallel, so in no fixed order), with how many are done, of how many, and its name.
using TrainingSetProgress = std::function<void(int done, int total, const std::string& name)>;

// What a material plan makes (plan_observations.h), under a name for the files (a preset's).
struct TrainingPlan {
  std::string name;
  std::vector<Observation> observations;
};

// `rig`: the rig's scene (its material gives only the pixel size); `observations`: what a
// material plan makes. The stack is written last: a stack names a complete pair.
Status RenderTrainingSet(const Scene& rig, const std::vector<Observation>& observations, const TrainingSetSpec& spec,
                         const std::filesystem::path& dir, const TrainingSetProgress& progress = {});
// Several plans (e.g. every gloss preset, for a model of the paper's input layout): material i
// is rendered with plans[i % plans.size()], and with two or more its files' names end in the
// plan's name (fabric-SEED-low.stack.exr).
Status RenderTrainingSet(const Scene& rig, const std::vector<TrainingPlan>& plans, const TrainingSetSpec& spec,
                         const std::filesystem::path& dir, const TrainingSetProgress& progress = {});

// A training set as `loom train` asks for it: a rig file and gloss presets (paths), each material
// rendered with the presets in turn. Refused before anything renders: a rig without `geometry:`
// (the simulator renders from it), and a set whose stacks rendered at once, or
// `resident_materials` of them held for training (0: all), do not fit in memory, or that does
// not fit on the disk of `dir` (unless `dir` holds a set already: its stacks are kept).
struct TrainingPreset {
  std::string name;  // the plan's, in the files' names when there are several
  std::filesystem::path file;
};
struct TrainingDatasetRequest {
  std::filesystem::path rig;
  std::vector<TrainingPreset> presets;
  TrainingSetSpec spec;
  int resident_materials = 0;
};
Status RenderTrainingDataset(const TrainingDatasetRequest& request, const std::filesystem::path& dir,
                             const TrainingSetProgress& progress = {});

}  // namespace loom::sim
