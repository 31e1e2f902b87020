#include "sim/training_set.h"

#include "core/file_io.h"
#include "core/memory.h"
#include "core/parallel.h"
#include "core/rig_file.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <mutex>

#include "scan/plan.h"
#include "sim/plan_observations.h"
#include "sim/rig_scene.h"
#include "sim/sample.h"

namespace loom::sim {

namespace fs = std::filesystem;

// Whether item i of a sequence is among a `share` of it spread evenly: i · share crosses an
// integer before (i + 1) · share.
bool Chosen(int i, double share) { return std::floor((i + 1) * share) > std::floor(i * share); }

Status TrainingSetSpec::Check() const {
  std::vector<std::string> problems;
  if (!(materials >= 1)) problems.push_back("materials must be >= 1");
  if (!(size_px >= 8 && size_px <= kMaxSampleSide)) {
    problems.push_back("size_px must be in [8, " + std::to_string(kMaxSampleSide) + "]");
  }
  if (!(out_of_model_share >= 0 && out_of_model_share <= 1)) problems.push_back("out_of_model_share must be in [0, 1]");
  if (!(scan_like_share >= 0 && scan_like_share <= 1)) problems.push_back("scan_like_share must be in [0, 1]");
  if (threads < 0) problems.push_back("threads must be >= 0");
  if (scan_like_share > 0) {
    if (Status checked = scan_emulation.Check(); !checked.ok()) problems.push_back(checked.message());
  }
  return ProblemsStatus("training set", problems);
}

nlohmann::json TrainingSetSpec::ToJson() const {
  nlohmann::json json = {{"materials", materials},
                         {"size_px", size_px},
                         {"first_seed", first_seed},
                         {"out_of_model_share", out_of_model_share},
                         {"scan_like_share", scan_like_share}};
  if (scan_like_share > 0) json["scan_emulation"] = scan_emulation.ToJson();
  return json;
}

Status RenderTrainingSet(const Scene& rig, const std::vector<Observation>& observations, const TrainingSetSpec& spec,
                         const fs::path& dir, const TrainingSetProgress& progress) {
  return RenderTrainingSet(rig, std::vector<TrainingPlan>{{"", observations}}, spec, dir, progress);
}

namespace {

// Material i of the set into `dir`, unless its two files are there already; its name in `name`.
Status RenderMaterial(const Scene& rig, const std::vector<TrainingPlan>& plans, const TrainingSetSpec& spec, int i,
                      const fs::path& dir, std::string& name) {
  const uint64_t seed = spec.first_seed + i;
  // Scan-likeness is chosen by pairs of materials, so that with out_of_model_share 0.5 (every
  // other material) half of each kind is scan-like.
  const bool out_of_model = Chosen(i, spec.out_of_model_share), scan_like = Chosen(i / 2, spec.scan_like_share);
  const TrainingPlan& plan = plans[static_cast<size_t>(i) % plans.size()];
  name = "fabric-" + std::to_string(seed) + (out_of_model ? "-out-of-model" : "") + (scan_like ? "-scan-like" : "") +
         (plans.size() > 1 ? "-" + plan.name : "");
  const fs::path stack_path = dir / (name + ".stack.exr"), truth_path = dir / (name + ".truth.exr");
  if (fs::exists(stack_path) && fs::exists(truth_path)) return Status::Ok();
  SampleSpec sample;
  sample.kind = out_of_model ? "fabric-out-of-model" : "fabric";
  sample.seed = seed;
  sample.size_px = spec.size_px;
  sample.pixel_mm = rig.material().pixel_mm;
  LOOM_ASSIGN_OR_RETURN(Material material, MakeSample(sample));
  const Scene scene(rig.rig(), std::move(material));
  ObservationStack stack = RenderStack(scene, plan.observations, {.threads = 1});
  if (scan_like) LOOM_RETURN_IF_ERROR(EmulateScan(spec.scan_emulation, seed, stack));
  LOOM_RETURN_IF_ERROR(WriteMaterial(TruthOnStackGrid(scene, {}), truth_path));
  return WriteObservationStack(stack_path, stack);
}

}  // namespace

Status RenderTrainingSet(const Scene& rig, const std::vector<TrainingPlan>& plans, const TrainingSetSpec& spec,
                         const fs::path& dir, const TrainingSetProgress& progress) {
  LOOM_RETURN_IF_ERROR(spec.Check());
  if (plans.empty()) return InvalidArgumentError("training set", "no plan to render the materials with");
  LOOM_RETURN_IF_ERROR(CreateDirectories(dir));
  // One material per thread: a training material is small (32² px), so the rows of one stack
  // keep few cores busy, and its fabric, truth and files are serial work.
  std::vector<Status> rendered(static_cast<size_t>(spec.materials));
  std::mutex progress_mutex;
  int done = 0;
  ParallelFor(spec.materials, spec.threads, [&](int i) {
    std::string name;
    rendered[static_cast<size_t>(i)] = RenderMaterial(rig, plans, spec, i, dir, name);
    const std::lock_guard<std::mutex> lock(progress_mutex);
    ++done;
    if (progress) progress(done, spec.materials, name);
  });
  for (const Status& status : rendered) LOOM_RETURN_IF_ERROR(status);
  return Status::Ok();
}

namespace {

// The dataset's stacks on disk, and those rendered at once and held for training in memory,
// checked before hours of rendering find the limit.
Status CheckDatasetFits(const TrainingDatasetRequest& request, const std::vector<TrainingPlan>& plans, const fs::path& dir) {
  const TrainingSetSpec& spec = request.spec;
  const uint64_t side = static_cast<uint64_t>(spec.size_px);
  uint64_t stack_bytes = 0;
  for (const TrainingPlan& plan : plans) stack_bytes += side * side * (kStackGeometryChannels + plan.observations.size()) * 4;
  const uint64_t materials = static_cast<uint64_t>(spec.materials);
  const uint64_t at_once = std::min<uint64_t>(materials, ThreadCount(spec.threads));
  const uint64_t resident = request.resident_materials > 0 ? static_cast<uint64_t>(request.resident_materials) : materials;
  const std::string what = "--size " + std::to_string(spec.size_px) + " × --materials " + std::to_string(materials);
  LOOM_RETURN_IF_ERROR(CheckFitsInMemory(std::max(at_once, std::min(resident, materials)) * stack_bytes,
                                         what + " (" + ReadableBytes(stack_bytes) + " per material's stack)"));
  std::error_code error;
  if (fs::exists(dir, error)) return Status::Ok();  // a dataset rendered before: its stacks are kept
  fs::path existing = fs::absolute(dir, error);
  while (!existing.empty() && !fs::exists(existing, error)) existing = existing.parent_path();
  const fs::space_info space = fs::space(existing, error);
  if (!error && space.available < materials * stack_bytes) {
    return OutOfRangeError(what, "the dataset needs about " + ReadableBytes(materials * stack_bytes) + " on disk and " +
                                     existing.string() + " has " + ReadableBytes(space.available) + " free");
  }
  return Status::Ok();
}

}  // namespace

Status RenderTrainingDataset(const TrainingDatasetRequest& request, const fs::path& dir, const TrainingSetProgress& progress) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Load(request.rig));
  if (!file.Has("geometry")) {
    return InvalidArgumentError(request.rig.string(),
                                "not a simulated rig (no 'geometry:'): training renders with the simulator");
  }
  LOOM_ASSIGN_OR_RETURN(const RigModel model, file.Model());
  LOOM_ASSIGN_OR_RETURN(const RigScene rig, MakeRigScene(file, model, ""));
  std::vector<TrainingPlan> plans;
  for (const TrainingPreset& preset : request.presets) {
    LOOM_ASSIGN_OR_RETURN(const scan::Preset loaded, scan::LoadPreset(preset.file));
    LOOM_ASSIGN_OR_RETURN(std::vector<Observation> observations, PresetObservations(rig.scene->rig(), loaded));
    plans.push_back({preset.name, std::move(observations)});
  }
  LOOM_RETURN_IF_ERROR(CheckDatasetFits(request, plans, dir));
  return RenderTrainingSet(*rig.scene, plans, request.spec, dir, progress);
}

}  // namespace loom::sim
