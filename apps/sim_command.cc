// loom sim material | render | capture | stats | match-scan: the simulator's materials (SVBRDF
// maps with preview PNGs), a simulated camera's frame or the fast-path stack (from the rig file
// alone: no device), photographs as other rigs take them (sim_capture_command.cc), the fabrics'
// parameter statistics, and how a scan's reconstruction differs from the fast path
// (sim/scan_emulation.h).
#include <filesystem>
#include <functional>
#include <iostream>
#include <optional>
#include <sstream>

#include "apps/command.h"
#include "apps/config_paths.h"
#include "core/exr_io.h"
#include "core/file_io.h"
#include "core/memory.h"
#include "core/observation_stack.h"
#include "core/output_directory.h"
#include "core/rig_file.h"
#include "fitting/report/export.h"
#include "scan/plan.h"
#include "scan/rig_state.h"
#include "sim/fabric_stats.h"
#include "sim/fast_path_stack.h"
#include "sim/object_capture.h"
#include "sim/plan_observations.h"
#include "sim/rig_scene.h"
#include "sim/sample.h"
#include "sim/scan_emulation.h"
#include "sim/stack.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

Status Material(const sim::SampleSpec& spec, const fs::path& out) {
  LOOM_ASSIGN_OR_RETURN(const sim::Material material, sim::MakeSample(spec));
  LOOM_ASSIGN_OR_RETURN(OutputDirectory staged, OutputDirectory::Create(out, "--out"));
  LOOM_RETURN_IF_ERROR(sim::WriteMaterial(material, staged.partial() / "svbrdf.exr"));
  LOOM_RETURN_IF_ERROR(fitting::WriteSvbrdfPreviews(material.maps, staged.partial()));
  LOOM_RETURN_IF_ERROR(staged.Commit());
  std::cout << material.name << " (" << material.width() << "x" << material.height() << " px of " << material.pixel_mm
            << " mm): " << (out / "svbrdf.exr").string() << " and previews in " << out.string() << "\n";
  return Status::Ok();
}

// Histograms of the generated fabrics' parameters over many seeds (sim/fabric_stats.h).
Status Stats(int seeds, int size_px, const std::string& json_path, bool force) {
  LOOM_RETURN_IF_ERROR(CheckOutputFiles({{"--json", json_path}}, force));
  const sim::FabricStatistics stats = sim::MeasureFabrics(seeds, size_px);
  stats.Report(std::cout);
  return WriteJsonReport(json_path, stats.ToJson());
}

struct RenderArguments {
  std::string rig, object, camera = "cam0", leds = "0:1000", preset = "low", truth, scan_emulation, out;
  double angle_deg = 0, exposure_us = 10000;
  bool stack = false, force = false;
  int size_px = 0;
  uint64_t seed = 1;
};

// The fast-path stack of the observations a material plan with the preset makes.
Status RenderStack(const sim::Scene& scene, const RenderArguments& args) {
  LOOM_ASSIGN_OR_RETURN(const scan::Preset preset, scan::LoadPreset(ResolvePresetPath(args.preset)));
  return sim::WriteFastPathStack(
      scene, preset,
      {.size_px = args.size_px, .out = args.out, .truth = args.truth, .scan_emulation = args.scan_emulation, .seed = args.seed},
      std::cout);
}

// One raw frame (and its radiance) of a simulated rig's camera, or the fast-path stack.
Status Render(const RenderArguments& args) {
  LOOM_RETURN_IF_ERROR(CheckOutputFiles({{"--out", args.out}, {"--truth", args.truth}}, args.force));
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Load(ResolveRigPath(args.rig)));
  if (!file.Has("geometry")) return InvalidArgumentError(args.rig, "not a simulated rig (it has no 'geometry:' section)");
  LOOM_ASSIGN_OR_RETURN(const RigModel model, file.Model());
  LOOM_ASSIGN_OR_RETURN(const sim::RigScene rig, sim::MakeRigScene(file, model, args.object));
  const std::shared_ptr<const sim::Scene> scene = rig.scene;
  if (args.stack) return RenderStack(*scene, args);
  sim::SceneState state;
  state.turntable_deg = args.angle_deg;
  LOOM_ASSIGN_OR_RETURN(const std::vector<scan::LedDrive> drives, scan::ParseLedDrives(args.leds, "--leds"));
  for (const scan::LedDrive& drive : drives) state.leds.push_back({drive.led, drive.current_ma});
  LOOM_ASSIGN_OR_RETURN(const Image image, sim::RenderCameraFrame(*scene, args.camera, state, {args.exposure_us, 0},
                                                                  static_cast<uint64_t>(file.Seed())));
  LOOM_RETURN_IF_ERROR(WriteExr(args.out, image, {{"loom.camera", args.camera}, {"loom.exposure_us", args.exposure_us}}));
  std::cout << "wrote " << args.out << ": radiance and raw DN of " << args.camera << "\n";
  return Status::Ok();
}

// How a reconstruction degrades a fast-path stack of the same material: blur, gains, noise.
Status MatchScan(const std::string& fast_path, const std::string& reconstructed_path, const std::string& emulation_path,
                 const std::string& json_path, bool force) {
  LOOM_RETURN_IF_ERROR(CheckOutputFiles({{"--out", emulation_path}, {"--json", json_path}}, force));
  LOOM_ASSIGN_OR_RETURN(const ObservationStack fast, ReadObservationStack(fast_path));
  LOOM_ASSIGN_OR_RETURN(const ObservationStack reconstructed, ReadObservationStack(reconstructed_path));
  LOOM_ASSIGN_OR_RETURN(const sim::ScanEmulationMatch match, sim::MatchScanEmulation(fast, reconstructed));
  match.Report(std::cout);
  if (!emulation_path.empty()) {
    LOOM_RETURN_IF_ERROR(WriteFileAtomically(emulation_path, match.emulation.ToYaml()));
    std::cout << "wrote " << emulation_path << ": the emulation, for loom train --scan-emulation\n";
  }
  return WriteJsonReport(json_path, match.ToJson());
}

}  // namespace

int RunSim(int argc, char** argv) {
  CLI::App app("The simulator: procedural materials and renders of a simulated rig", "loom sim");
  AddCommonOptions(app);
  app.require_subcommand(1);
  sim::SampleSpec sample;  // a fabric, seed 0, 256 px of 0.1 mm
  std::string out;
  CLI::App* material = app.add_subcommand("material", "Write a material's SVBRDF maps (OpenEXR) and preview PNGs");
  material->add_option("--kind", sample.kind,
                       "fabric, fabric-out-of-model (with what GD10 cannot represent), white-tile, chessboard, colour-chart");
  material->add_option("--seed", sample.seed, "Seed of a procedural fabric (same seed, same maps)");
  material->add_option("--size", sample.size_px, "Map size in pixels (square)")->check(CLI::Range(8, 8192));
  material->add_option("--pixel-mm", sample.pixel_mm, "Map pixel size on the sample in mm")->check(CLI::PositiveNumber);
  material->add_option("--out", out, "Output directory")->required();
  RenderArguments r;
  CLI::App* render =
      app.add_subcommand("render", "Render one camera frame (radiance + raw DN) or, with --stack, the fast-path stack");
  render->add_option("--rig", r.rig, "Simulated rig YAML (with geometry:), or its name in configs/rig/")->required();
  render->add_option("--object", r.object, "What lies on the turntable instead of the rig's sample (as loom scan --object)");
  render->add_option("--camera", r.camera, "Camera of the rig geometry");
  render->add_option("--leds", r.leds, "LED:MILLIAMPS[,...] lit for the frame");
  render->add_option("--turntable-deg", r.angle_deg, "Turntable angle");
  render->add_option("--exposure-us", r.exposure_us, "Exposure of the raw frame");
  render->add_flag("--stack", r.stack, "Render the observation stack in the top-view frame instead");
  render->add_option("--preset", r.preset, "With --stack: the gloss preset whose material plan gives the observations");
  render->add_option("--size", r.size_px, "With --stack: its size in pixels (square, centred; 0: the sample's)")
      ->check(CLI::Range(0, 8192));
  render->add_option("--truth", r.truth, "With --stack: also write the ground-truth maps on its grid (OpenEXR)");
  render->add_option("--scan-emulation", r.scan_emulation,
                     "With --stack: degrade it as a scan's reconstruction would (a loom sim match-scan --out YAML)");
  render->add_option("--seed", r.seed, "With --scan-emulation: the seed of its gains and noise");
  render->add_option("--out", r.out, "Output EXR")->required();
  AddForceOption(*render, r.force);
  const std::function<Status()> capture = AddSimCaptureCommand(app);
  int seeds = 200, stats_size_px = 256;
  std::string json_path;
  CLI::App* stats = app.add_subcommand("stats", "Histograms of the procedural fabrics' parameters over many seeds");
  stats->add_option("--seeds", seeds, "Seeds 0..N-1")->check(CLI::Range(1, 100000));
  stats->add_option("--size", stats_size_px, "Map size per fabric")->check(CLI::Range(8, 4096));
  stats->add_option("--json", json_path, "Also write the histograms as JSON");
  bool force = false;
  AddForceOption(*stats, force);
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
  AddForceOption(*match_scan, force);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  Status done;
  if (*match_scan) done = MatchScan(fast_path, reconstructed_path, emulation_path, json_path, force);
  if (*stats) done = Stats(seeds, stats_size_px, json_path, force);
  if (*render) done = Render(r);
  if (app.got_subcommand("capture")) done = capture();
  if (*material) done = Material(sample, out);
  return ExitCode(done);
}

}  // namespace loom::apps
