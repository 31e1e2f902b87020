// loom demo: the main job on a simulated rig, end to end — calibration scan → loom calibrate
// geometry and radiometry (or, with --no-calibration, the rig YAML's) → material scan of a
// procedural fabric (or of a crop of it, --crop-mm) → loom reconstruct with that calibration →
// loom fit (each method asked for) → loom eval against the simulator's ground truth → loom export
// of the main result as glTF and AxF — then a one-screen summary and summary.json. Every stage is the
// loom command of the same name, run in this process with the arguments it prints, so what the
// demo does a user can repeat by hand.
#include <chrono>
#include <filesystem>
#include <future>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "apps/command.h"
#include "apps/rig_loader.h"
#include "core/file_io.h"
#include "core/version.h"
#include "fitting/report/report.h"
#include "fitting/solve/stack_fitter.h"
#include "reconstruction/reconstruct.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

struct DemoArguments {
  std::string rig = "tac7-mini";
  std::string object = "fabric:1";
  std::string preset = "low";
  std::string out = "loom-demo";
  std::vector<std::string> methods = {"cnn", "cnn+refine"};
  int size_px = 0;        // 0: the reconstruction's default
  double crop_mm = 0;     // > 0: the material scan reads only the windows that see this crop
  bool calibrate = true;  // false: reconstruct with the rig YAML's geometry and radiometry
  bool quiet = false;
};

struct StageTime {
  std::string name;
  double seconds = 0;
};

// Runs loom commands in this process, one stage each, and keeps how long each took. Two stages
// may run at once, on two threads.
class Stages {
 public:
  explicit Stages(bool quiet) : quiet_(quiet) {}

  Status Run(const std::string& name, int (*command)(int, char**), std::vector<std::string> arguments) {
    if (quiet_ && (arguments[0] == "scan" || arguments[0] == "reconstruct" || arguments[0] == "fit")) {
      arguments.push_back("--quiet");
    }
    std::cout << "\n== " << name << ": loom";
    for (const std::string& argument : arguments) std::cout << " " << argument;
    std::cout << std::endl;
    std::vector<char*> argv;
    for (std::string& argument : arguments) argv.push_back(argument.data());
    const auto start = std::chrono::steady_clock::now();
    const int exit = command(static_cast<int>(argv.size()), argv.data());
    {
      std::lock_guard lock(mutex_);
      times_.push_back({name, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()});
    }
    std::cout.flush();
    if (exit != kExitOk) {
      return InternalError("demo stage '" + name + "'", "failed (exit " + std::to_string(exit) + "; its message is above)");
    }
    return Status::Ok();
  }

  const std::vector<StageTime>& times() const { return times_; }

 private:
  bool quiet_;
  std::mutex mutex_;
  std::vector<StageTime> times_;
};

std::vector<std::string> WithSize(std::vector<std::string> arguments, int size_px) {
  if (size_px > 0) arguments.insert(arguments.end(), {"--size", std::to_string(size_px)});
  return arguments;
}

Status ScanMaterial(const DemoArguments& args, const std::string& rig, Stages* stages) {
  const fs::path out(args.out);
  std::vector<std::string> scan = {
      "scan", "--rig", rig, "--preset", args.preset, "--object", args.object, "--out", (out / "scan").string()};
  if (args.crop_mm > 0) {
    std::ostringstream crop;
    crop << args.crop_mm;
    scan.insert(scan.end(), {"--crop-mm", crop.str()});
  }
  return stages->Run("material scan", RunScan, scan);
}

// Geometry, then radiometry, from the calibration scan in `out`.
Status Calibrate(const fs::path& out, Stages* stages) {
  const std::string scan = (out / "calibration-scan").string(), calib = (out / "calib").string();
  LOOM_RETURN_IF_ERROR(stages->Run("calibrate geometry", RunCalibrate, {"calibrate", "geometry", scan, "--out", calib}));
  return stages->Run("calibrate radiometry", RunCalibrate, {"calibrate", "radiometry", scan, "--calib", calib});
}

Status CalibrateAndScan(const DemoArguments& args, const std::string& rig, Stages* stages) {
  const fs::path out(args.out);
  if (args.calibrate) {
    std::vector<std::string> calibration_scan = {"scan",          "--rig", rig,
                                                 "--calibration", "--out", (out / "calibration-scan").string()};
    // A rig whose material scan reads a crop has sensors too large to read whole for every view
    // of a calibration object.
    if (args.crop_mm > 0) calibration_scan.push_back("--object-windows");
    LOOM_RETURN_IF_ERROR(stages->Run("calibration scan", RunScan, calibration_scan));
  }
  // Calibrating needs the calibration scan, not the rig: it runs while the rig scans the
  // material, as a lab's would. Here the simulated scan keeps both cores busy, and the
  // calibration's stretches on one core fill what it leaves (tac7's demo 15 min 20 s -> 14 min 38 s).
  std::future<Status> calibrated =
      std::async(std::launch::async, [&] { return args.calibrate ? Calibrate(out, stages) : Status::Ok(); });
  const Status scanned = ScanMaterial(args, rig, stages);
  const Status calibration = calibrated.get();
  LOOM_RETURN_IF_ERROR(scanned);
  LOOM_RETURN_IF_ERROR(calibration);
  std::vector<std::string> reconstruct = {"reconstruct", (out / "scan").string(), "--out", (out / "reconstruction").string()};
  if (args.calibrate) reconstruct.insert(reconstruct.end(), {"--calib", (out / "calib").string()});
  return stages->Run("reconstruct", RunReconstruct, WithSize(reconstruct, args.size_px));
}

Status FitAndEvaluate(const DemoArguments& args, const std::string& rig, Stages* stages) {
  const fs::path out(args.out);
  const std::string stack = (out / "reconstruction" / "stack.exr").string();
  LOOM_RETURN_IF_ERROR(
      stages->Run("ground truth", RunSim,
                  WithSize({"sim", "render", "--rig", rig, "--object", args.object, "--stack", "--preset", args.preset, "--truth",
                            (out / "truth.exr").string(), "--out", (out / "fast-path-stack.exr").string()},
                           args.size_px)));
  for (const std::string& method : args.methods) {
    const std::string fit = (out / ("fit-" + method)).string();
    LOOM_RETURN_IF_ERROR(stages->Run("fit " + method, RunFit, {"fit", stack, "--method", method, "--out", fit}));
    LOOM_RETURN_IF_ERROR(stages->Run("evaluate " + method, RunEval,
                                     {"eval", fit + "/svbrdf.exr", "--stack", stack, "--reference", (out / "truth.exr").string(),
                                      "--out", (out / ("report-" + method)).string(), "--title",
                                      args.object + " on " + rig + " (scan → calibrate → reconstruct → " + method + ")"}));
  }
  return stages->Run("export", RunExport,
                     {"export", (out / ("fit-" + args.methods.back()) / "svbrdf.exr").string(), "--gltf", (out / "gltf").string(),
                      "--axf", (out / "material.axf").string()});
}

Result<nlohmann::ordered_json> ReadJson(const fs::path& path) {
  LOOM_ASSIGN_OR_RETURN(const std::string text, ReadFile(path));
  nlohmann::ordered_json json = nlohmann::ordered_json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return InvalidArgumentError(path.string(), "not JSON");
  return json;
}

// The evaluations and stage times as one document.
Result<nlohmann::ordered_json> Summarise(const DemoArguments& args, const std::string& rig, const Stages& stages,
                                         double wall_seconds) {
  const fs::path out(args.out);
  nlohmann::ordered_json summary = {
      {"rig", rig}, {"object", args.object}, {"preset", args.preset}, {"loom_version", std::string(VersionWithCommit())}};
  summary["calibration_rms_px"] = nullptr;  // none: the rig YAML's geometry
  if (args.calibrate) {
    LOOM_ASSIGN_OR_RETURN(const nlohmann::ordered_json geometry, ReadJson(out / "calib" / "geometry.json"));
    summary["calibration_rms_px"] = geometry["rms_px"];
  }
  if (args.crop_mm > 0) summary["crop_mm"] = args.crop_mm;
  for (const StageTime& stage : stages.times()) summary["stage_seconds"][stage.name] = stage.seconds;
  summary["wall_seconds"] = wall_seconds;  // less than the stages' sum: calibrating ran during the material scan
  for (const std::string& method : args.methods) {
    LOOM_ASSIGN_OR_RETURN(nlohmann::ordered_json evaluation, ReadJson(out / ("report-" + method) / "summary.json"));
    evaluation["report"] = (out / ("report-" + method) / "index.html").string();
    summary["methods"][method] = std::move(evaluation);
  }
  return summary;
}

void PrintSummary(const nlohmann::ordered_json& summary) {
  std::cout << "\n== summary: " << summary["object"].get<std::string>() << " on " << summary["rig"].get<std::string>()
            << ", preset " << summary["preset"].get<std::string>() << "; ";
  if (summary["calibration_rms_px"].is_null()) {
    std::cout << "not calibrated (the rig YAML's geometry)\n";
  } else {
    std::cout << "camera calibration RMS " << std::fixed << std::setprecision(3) << summary["calibration_rms_px"].get<double>()
              << " px\n";
  }
  fitting::PrintEvaluationTable(std::cout, summary["methods"]);
  std::cout << "\ntime per stage (calibrating during the material scan):";
  for (const auto& [stage, seconds] : summary["stage_seconds"].items()) {
    std::cout << "\n  " << std::left << std::setw(22) << stage << std::right << FormatDuration(seconds.get<double>());
  }
  std::cout << "\n  " << std::left << std::setw(22) << "total (wall clock)" << std::right
            << FormatDuration(summary["wall_seconds"].get<double>()) << "\n";
}

Status Demo(const DemoArguments& args) {
  const std::string rig = ResolveRigPath(args.rig).string();
  if (!fs::exists(rig)) return NotFoundError("--rig " + args.rig, "no such file, nor configs/rig/" + args.rig + ".yaml");
  LOOM_RETURN_IF_ERROR(CheckDirectoryOutputPath(args.out, "--out"));
  if (fs::exists(args.out) && !fs::is_empty(args.out)) {
    return AlreadyExistsError(args.out, "is not empty: the demo writes a fresh directory (remove it, or pick another --out)");
  }
  Stages stages(args.quiet);
  const auto start = std::chrono::steady_clock::now();
  LOOM_RETURN_IF_ERROR(CalibrateAndScan(args, rig, &stages));
  LOOM_RETURN_IF_ERROR(FitAndEvaluate(args, rig, &stages));
  const double wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  LOOM_ASSIGN_OR_RETURN(const nlohmann::ordered_json summary, Summarise(args, rig, stages, wall_seconds));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(fs::path(args.out) / "summary.json", summary.dump(2) + "\n"));
  PrintSummary(summary);
  std::cout << "\nsummary: " << (fs::path(args.out) / "summary.json").string()
            << "\nreport:  " << summary["methods"][args.methods.back()]["report"].get<std::string>()
            << "\nglTF:    " << (fs::path(args.out) / "gltf" / "material.gltf").string() << "\n";
  return Status::Ok();
}

std::vector<std::string> FitMethodNames() {
  std::vector<std::string> names;
  for (fitting::FitMethod method : fitting::kFitMethods) names.emplace_back(fitting::FitMethodName(method));
  return names;
}

}  // namespace

int RunDemo(int argc, char** argv) {
  CLI::App app(
      "The main job on a simulated rig: calibration scan, calibrate, scan a procedural fabric, reconstruct, "
      "fit, evaluate against the ground truth, summarise",
      "loom demo");
  AddCommonOptions(app);
  DemoArguments args;
  app.add_option("--rig", args.rig, "Simulated rig: a name in configs/rig/ or a YAML file (default tac7-mini)");
  app.add_option("--object", args.object, "The material: fabric:SEED or fabric-out-of-model:SEED (default fabric:1)");
  app.add_option("--preset", args.preset, "Gloss preset of the material scan (default low)");
  app.add_option("--methods", args.methods, "Fit methods, in order, the last being the main result (default cnn cnn+refine)")
      ->delimiter(',')
      ->check(CLI::IsMember(FitMethodNames()));
  app.add_option("--size", args.size_px,
                 "Stack size in pixels (square, centred; default: reconstruct's); the scans then read only that crop "
                 "(--crop-mm of the size at reconstruct's pixel size) unless --crop-mm says otherwise")
      ->check(CLI::Range(8, 8192));
  app.add_option("--crop-mm", args.crop_mm,
                 "Scan only a centred square crop of the sample this wide, each camera reading the window that sees it "
                 "(as loom scan --crop-mm; for rigs with large sensors, e.g. tac7 with --size 64 and 12.8); the "
                 "calibration scan then reads each calibration object through its windows (loom scan --object-windows)")
      ->check(CLI::Range(0.5, 1000.0));
  app.add_flag("!--no-calibration", args.calibrate,
               "No calibration scan: reconstruct with the rig YAML's geometry and radiometry (on a simulated rig without "
               "as_built: that is what it is)");
  app.add_option("--out", args.out, "Directory to write, new or empty (default loom-demo)");
  app.add_flag("--quiet", args.quiet, "No progress bars");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  // A demo that reconstructs a crop scans only that crop: on tac7's 2048 × 1536 sensors a whole
  // material scan takes hours here, the 12.8 mm that --size 64 reconstructs a few minutes.
  if (args.crop_mm == 0 && args.size_px > 0) args.crop_mm = args.size_px * reconstruction::ReconstructOptions{}.pixel_mm;
  return ExitCode(Demo(args));
}

}  // namespace loom::apps
