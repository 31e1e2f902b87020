// loom sim material | render | stats | match-scan: the simulator's materials (SVBRDF maps with
// preview PNGs), a simulated camera's frame or the fast-path stack, the fabrics' parameter
// statistics, and how a scan's reconstruction differs from the fast path (sim/scan_emulation.h).
#include <filesystem>
#include <iostream>

#include "apps/command.h"
#include "apps/rig_loader.h"
#include "core/exr_io.h"
#include "core/file_io.h"
#include "core/observation_stack.h"
#include "fitting/export.h"
#include "scan/plan.h"
#include "scan/rig_state.h"
#include "sim/fabric_stats.h"
#include "sim/plan_observations.h"
#include "sim/sample.h"
#include "sim/scan_emulation.h"
#include "sim/stack.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

int Material(const std::string& kind, uint64_t seed, int size_px, double pixel_mm, const fs::path& out) {
  sim::SampleSpec spec;
  spec.kind = kind;
  spec.seed = seed;
  spec.size_px = size_px;
  spec.pixel_mm = pixel_mm;
  Result<sim::Material> material = sim::MakeSample(spec);
  if (!material.ok()) return ReportFailure(material.status());
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) return ReportFailure(IoError(out.string(), "cannot create: " + ec.message()));
  const fs::path maps = out / "svbrdf.exr";
  if (Status written = sim::WriteMaterial(*material, maps); !written.ok()) return ReportFailure(written);
  if (Status previews = fitting::WriteSvbrdfPreviews(material->maps, out); !previews.ok()) return ReportFailure(previews);
  std::cout << material->name << " (" << material->width() << "x" << material->height() << " px of " << material->pixel_mm
            << " mm): " << maps.string() << " and previews in " << out.string() << "\n";
  return kExitOk;
}

// Histograms of the generated fabrics' parameters over many seeds (sim/fabric_stats.h).
int Stats(int seeds, int size_px, const std::string& json_path) {
  const sim::FabricStatistics stats = sim::MeasureFabrics(seeds, size_px);
  stats.Report(std::cout);
  if (!json_path.empty()) {
    if (Status written = WriteFileAtomically(json_path, stats.ToJson().dump(2) + "\n"); !written.ok()) {
      return ReportFailure(written);
    }
    std::cout << "wrote " << json_path << "\n";
  }
  return kExitOk;
}

// One raw frame (and its radiance) of a simulated rig's camera, or the fast-path stack.
// The fast-path stack of the observations a material plan with `preset` makes.
int RenderStack(const LoadedRig& loaded, const std::string& preset_name, int size_px, const std::string& truth_path,
                const fs::path& out) {
  const std::shared_ptr<const sim::Scene> scene_owner = loaded.sim->world->scene();
  const sim::Scene& scene = *scene_owner;
  Result<scan::Preset> preset = scan::LoadPreset(ResolvePresetPath(preset_name));
  if (!preset.ok()) return ReportFailure(preset.status());
  Result<scan::Plan> plan = scan::MakeMaterialPlan(scene.rig(), *preset);
  if (!plan.ok()) return ReportFailure(plan.status());
  Result<std::vector<sim::Observation>> observations = sim::PlanObservations(scene.rig(), *plan);
  if (!observations.ok()) return ReportFailure(observations.status());
  const sim::StackOptions options{.width_px = size_px, .height_px = size_px};
  const ObservationStack stack = sim::RenderStack(scene, *observations, options);
  if (Status written = WriteObservationStack(out, stack); !written.ok()) return ReportFailure(written);
  if (!truth_path.empty()) {
    if (Status written = sim::WriteMaterial(sim::TruthOnStackGrid(scene, options), truth_path); !written.ok()) {
      return ReportFailure(written);
    }
    std::cout << "wrote " << truth_path << ": the ground-truth maps on the stack's grid\n";
  }
  std::cout << "wrote " << out.string() << ": " << stack.image.width() << "x" << stack.image.height() << " px, "
            << observations->size() << " observations (preset " << preset->name << ")\n";
  return kExitOk;
}

int Render(const std::string& rig_path, const std::string& object, const std::string& camera_name, const std::string& leds,
           double angle_deg, double exposure_us, bool stack, const std::string& preset, int size_px,
           const std::string& truth_path, const fs::path& out) {
  Result<LoadedRig> loaded = LoadRig(rig_path, object);
  if (!loaded.ok()) return ReportFailure(loaded.status());
  if (!loaded->sim) {
    return ReportFailure(InvalidArgumentError(rig_path, "not a simulated rig (it has no 'geometry:' section)"));
  }
  if (stack) return RenderStack(*loaded, preset, size_px, truth_path, out);
  sim::SceneState state;
  state.turntable_deg = angle_deg;
  Result<std::vector<scan::LedDrive>> drives = scan::ParseLedDrives(leds, "--leds");
  if (!drives.ok()) return ReportFailure(drives.status());
  for (const scan::LedDrive& drive : *drives) state.leds.push_back({drive.led, drive.current_ma});
  const Result<Image> image =
      sim::RenderCameraFrame(*loaded->sim->world->scene(), camera_name, state, {exposure_us, 0}, loaded->sim->world->seed);
  if (!image.ok()) return ReportFailure(image.status());
  if (Status written = WriteExr(out, *image, {{"loom.camera", camera_name}, {"loom.exposure_us", exposure_us}}); !written.ok()) {
    return ReportFailure(written);
  }
  std::cout << "wrote " << out.string() << ": radiance and raw DN of " << camera_name << "\n";
  return kExitOk;
}

// How a reconstruction degrades a fast-path stack of the same material: blur, gains, noise.
int MatchScan(const std::string& fast_path, const std::string& reconstructed_path, const std::string& emulation_path,
              const std::string& json_path) {
  Result<ObservationStack> fast = ReadObservationStack(fast_path);
  if (!fast.ok()) return ReportFailure(fast.status());
  Result<ObservationStack> reconstructed = ReadObservationStack(reconstructed_path);
  if (!reconstructed.ok()) return ReportFailure(reconstructed.status());
  Result<sim::ScanEmulationMatch> match = sim::MatchScanEmulation(*fast, *reconstructed);
  if (!match.ok()) return ReportFailure(match.status());
  match->Report(std::cout);
  if (!emulation_path.empty()) {
    if (Status written = WriteFileAtomically(emulation_path, match->emulation.ToYaml()); !written.ok()) {
      return ReportFailure(written);
    }
    std::cout << "wrote " << emulation_path << ": the emulation, for loom train --scan-emulation\n";
  }
  if (!json_path.empty()) {
    if (Status written = WriteFileAtomically(json_path, match->ToJson().dump(2) + "\n"); !written.ok()) {
      return ReportFailure(written);
    }
  }
  return kExitOk;
}

}  // namespace

int RunSim(int argc, char** argv) {
  CLI::App app("The simulator: procedural materials and renders of a simulated rig", "loom sim");
  AddCommonOptions(app);
  app.require_subcommand(1);
  std::string kind = "fabric";
  uint64_t seed = 0;
  int size_px = 256;
  double pixel_mm = 0.1;
  std::string out;
  CLI::App* material = app.add_subcommand("material", "Write a material's SVBRDF maps (OpenEXR) and preview PNGs");
  material->add_option("--kind", kind,
                       "fabric (procedural, by seed), fabric-out-of-model (the same with what GD10 cannot represent), "
                       "white-tile, chessboard, colour-chart");
  material->add_option("--seed", seed, "Seed of a procedural fabric (same seed, same maps)");
  material->add_option("--size", size_px, "Map size in pixels (square)")->check(CLI::Range(8, 8192));
  material->add_option("--pixel-mm", pixel_mm, "Map pixel size on the sample in mm")->check(CLI::PositiveNumber);
  material->add_option("--out", out, "Output directory")->required();
  std::string rig_path, camera = "cam0", leds = "0:1000";
  double angle_deg = 0, exposure_us = 10000;
  bool stack = false;
  std::string preset = "low";
  CLI::App* render = app.add_subcommand("render",
                                        "Render one camera frame (radiance + raw DN) or, with --stack, "
                                        "the fast-path observation stack");
  render->add_option("--rig", rig_path, "Simulated rig YAML (with geometry:)")->required();
  std::string object;
  render->add_option("--object", object,
                     "What lies on the turntable instead of the rig's sample: fabric:SEED, "
                     "fabric-out-of-model:SEED, white-tile, chessboard, colour-chart");
  render->add_option("--camera", camera, "Camera of the rig geometry");
  render->add_option("--leds", leds, "LED:MILLIAMPS[,...] lit for the frame");
  render->add_option("--turntable-deg", angle_deg, "Turntable angle");
  render->add_option("--exposure-us", exposure_us, "Exposure of the raw frame");
  render->add_flag("--stack", stack, "Render the observation stack in the top-view frame instead");
  render->add_option("--preset", preset, "With --stack: the gloss preset whose material plan gives the observations");
  int stack_size_px = 0;
  std::string truth_path;
  render->add_option("--size", stack_size_px, "With --stack: its size in pixels (square, centred; 0: the sample's)")
      ->check(CLI::Range(0, 8192));
  render->add_option("--truth", truth_path, "With --stack: also write the ground-truth maps on its grid (OpenEXR)");
  render->add_option("--out", out, "Output EXR")->required();
  int seeds = 200;
  std::string json_path;
  CLI::App* stats = app.add_subcommand("stats", "Histograms of the procedural fabrics' parameters over many seeds");
  stats->add_option("--seeds", seeds, "Seeds 0..N-1")->check(CLI::Range(1, 100000));
  stats->add_option("--size", size_px, "Map size per fabric")->check(CLI::Range(8, 4096));
  stats->add_option("--json", json_path, "Also write the histograms as JSON");
  std::string fast_path, reconstructed_path;
  CLI::App* match_scan = app.add_subcommand("match-scan",
                                            "Measure how a reconstructed stack differs from the fast path of the same "
                                            "material (camera blur, gains, noise): the training data's scan emulation");
  match_scan->add_option("--fast", fast_path, "Fast-path stack (sim render --stack)")->required();
  match_scan->add_option("--reconstructed", reconstructed_path, "Reconstructed stack of a scan of the same material, same grid")
      ->required();
  std::string emulation_path;
  match_scan->add_option("--out", emulation_path, "Write the fitted emulation (YAML) for loom train --scan-emulation");
  match_scan->add_option("--json", json_path, "Also write the measurement as JSON");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  if (*match_scan) return MatchScan(fast_path, reconstructed_path, emulation_path, json_path);
  if (*stats) return Stats(seeds, size_px, json_path);
  if (*render) {
    return Render(rig_path, object, camera, leds, angle_deg, exposure_us, stack, preset, stack_size_px, truth_path, out);
  }
  return Material(kind, seed, size_px, pixel_mm, out);
}

}  // namespace loom::apps
