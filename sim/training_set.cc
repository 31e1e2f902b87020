#include "sim/training_set.h"

#include <cmath>

#include "sim/sample.h"

namespace loom::sim {

namespace fs = std::filesystem;

Status TrainingSetSpec::Check() const {
  std::vector<std::string> problems;
  if (!(materials >= 1)) problems.push_back("materials must be >= 1");
  if (!(size_px >= 8 && size_px <= kMaxSampleSide)) {
    problems.push_back("size_px must be in [8, " + std::to_string(kMaxSampleSide) + "]");
  }
  if (!(out_of_model_share >= 0 && out_of_model_share <= 1)) problems.push_back("out_of_model_share must be in [0, 1]");
  return ProblemsStatus("training set", problems);
}

Status RenderTrainingSet(const Scene& rig, const std::vector<Observation>& observations, const TrainingSetSpec& spec,
                         const fs::path& dir, const TrainingSetProgress& progress) {
  LOOM_RETURN_IF_ERROR(spec.Check());
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return IoError(dir.string(), "cannot create: " + ec.message());
  for (int i = 0; i < spec.materials; ++i) {
    const uint64_t seed = spec.first_seed + i;
    // Material i is out of model when i · share crosses an integer before (i + 1) · share.
    const bool out_of_model = std::floor((i + 1) * spec.out_of_model_share) > std::floor(i * spec.out_of_model_share);
    const std::string name = "fabric-" + std::to_string(seed) + (out_of_model ? "-out-of-model" : "");
    const fs::path stack_path = dir / (name + ".stack.exr"), truth_path = dir / (name + ".truth.exr");
    if (!fs::exists(stack_path) || !fs::exists(truth_path)) {
      SampleSpec sample;
      sample.kind = out_of_model ? "fabric-out-of-model" : "fabric";
      sample.seed = seed;
      sample.size_px = spec.size_px;
      sample.pixel_mm = rig.material().pixel_mm;
      LOOM_ASSIGN_OR_RETURN(Material material, MakeSample(sample));
      const Scene scene(rig.rig(), std::move(material));
      const ObservationStack stack = RenderStack(scene, observations, {});
      LOOM_RETURN_IF_ERROR(WriteMaterial(TruthOnStackGrid(scene, {}), truth_path));
      LOOM_RETURN_IF_ERROR(WriteObservationStack(stack_path, stack));
    }
    if (progress) progress(i + 1, spec.materials, name);
  }
  return Status::Ok();
}

}  // namespace loom::sim
