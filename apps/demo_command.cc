// loom demo: the main job on a simulated rig, end to end — calibration scan → geometric and
// radiometric calibration (or, with --no-calibration, the rig YAML's) → material scan of a
// procedural fabric (or of a crop of it, --crop-mm) → reconstruction with that calibration → fit
// (each method asked for) → evaluation against the simulator's ground truth → export of the main
// result as glTF and AxF — then a one-screen summary and summary.json. Each stage calls the
// library function its loom command calls, with that command's defaults, and prints the command
// that repeats it by hand.
#include <chrono>
#include <filesystem>
#include <functional>
#include <future>
#include <iomanip>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>

#include <nlohmann/json.hpp>

#include "apps/command.h"
#include "apps/config_paths.h"
#include "apps/progress.h"
#include "apps/rig_loader.h"
#include "apps/scanning.h"
#include "calibration/scan_calibration.h"
#include "core/file_io.h"
#include "core/version.h"
#include "fitting/fit_directory.h"
#include "fitting/report/evaluate_directory.h"
#include "fitting/report/export_maps.h"
#include "fitting/report/report.h"
#include "reconstruction/scan_reconstruction.h"
#include "sim/fast_path_stack.h"

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

// Runs the stages and keeps how long each took. Two stages may run at once, on two threads.
class Stages {
 public:
  // `command`: the loom command line that does the same by hand, printed before the stage runs.
  Status Run(const std::string& name, const std::string& command, const std::function<Status()>& stage) {
    std::cout << "\n== " << name << ": loom " << command << std::endl;
    const auto start = std::chrono::steady_clock::now();
    const Status done = stage();
    {
      std::lock_guard lock(mutex_);
      times_.push_back({name, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()});
    }
    std::cout.flush();
    if (!done.ok()) return done.WithContext("demo stage '" + name + "'");
    return Status::Ok();
  }

  const std::vector<StageTime>& times() const { return times_; }

 private:
  std::mutex mutex_;
  std::vector<StageTime> times_;
};

std::string SizeOption(int size_px) { return size_px > 0 ? " --size " + std::to_string(size_px) : ""; }

Status ScanMaterial(const DemoArguments& args, const std::string& rig, Stages* stages) {
  NewScanRequest scan;
  scan.rig_path = rig;
  scan.preset = args.preset;
  scan.object = args.object;
  scan.crop_mm = args.crop_mm;
  scan.out = fs::path(args.out) / "scan";
  scan.quiet = args.quiet;
  std::ostringstream command;
  command << "scan --rig " << rig << " --preset " << args.preset << " --object " << args.object << " --out " << scan.out.string();
  if (args.crop_mm > 0) command << " --crop-mm " << args.crop_mm;
  return stages->Run("material scan", command.str(), [&] { return NewScan(scan); });
}

// Geometry, then radiometry, from the calibration scan in `out`.
Status Calibrate(const fs::path& out, Stages* stages) {
  const fs::path scan = out / "calibration-scan", calib = out / "calib";
  LOOM_RETURN_IF_ERROR(
      stages->Run("calibrate geometry", "calibrate geometry " + scan.string() + " --out " + calib.string(), [&]() -> Status {
        LOOM_ASSIGN_OR_RETURN(const calibration::GeometryCalibration geometry,
                              calibration::CalibrateGeometryToDirectory(scan, calib));
        geometry.Report(std::cout);
        return Status::Ok();
      }));
  return stages->Run("calibrate radiometry", "calibrate radiometry " + scan.string() + " --calib " + calib.string(),
                     [&]() -> Status {
                       LOOM_ASSIGN_OR_RETURN(const calibration::RadiometryCalibration radiometry,
                                             calibration::CalibrateRadiometryFromScan(scan, calib, ""));
                       for (const std::string& note : radiometry.notes) std::cerr << note << "\n";
                       LOOM_RETURN_IF_ERROR(radiometry.Write(calib));
                       radiometry.Report(std::cout);
                       return Status::Ok();
                     });
}

Status CalibrationScan(const DemoArguments& args, const std::string& rig, Stages* stages) {
  // A rig whose material scan reads a crop has sensors too large to read whole for every view
  // of a calibration object.
  NewScanRequest scan;
  scan.rig_path = rig;
  scan.calibration = true;
  scan.object_windows = args.crop_mm > 0;
  scan.out = fs::path(args.out) / "calibration-scan";
  scan.quiet = args.quiet;
  const std::string command =
      "scan --rig " + rig + " --calibration --out " + scan.out.string() + (scan.object_windows ? " --object-windows" : "");
  return stages->Run("calibration scan", command, [&] { return NewScan(scan); });
}

Status Reconstruct(const DemoArguments& args, Stages* stages) {
  const fs::path out(args.out);
  reconstruction::ReconstructOptions options;
  if (args.size_px > 0) options.width_px = options.height_px = args.size_px;
  const fs::path calib = args.calibrate ? out / "calib" : fs::path();
  const std::string command = "reconstruct " + (out / "scan").string() + " --out " + (out / "reconstruction").string() +
                              (args.calibrate ? " --calib " + calib.string() : "") + SizeOption(args.size_px);
  return stages->Run("reconstruct", command, [&]() -> Status {
    std::map<std::string, ProgressBar> bars;
    const auto progress = [&](const reconstruction::ReconstructProgress& p) {
      bars.try_emplace(p.stage, "reconstruct: " + p.stage, args.quiet)
          .first->second.Update(p.done, p.total, p.stage == "heightmap" ? "steps" : "views");
    };
    LOOM_ASSIGN_OR_RETURN(const reconstruction::ReconstructedDirectory written,
                          reconstruction::ReconstructToDirectory(out / "scan", calib, options, out / "reconstruction", progress));
    bars.clear();
    for (const std::string& note : written.scanned.notes) std::cerr << "note: " << note << "\n";
    written.Report(std::cout);
    return Status::Ok();
  });
}

Status CalibrateAndScan(const DemoArguments& args, const std::string& rig, Stages* stages) {
  if (args.calibrate) LOOM_RETURN_IF_ERROR(CalibrationScan(args, rig, stages));
  // Calibrating needs the calibration scan, not the rig: it runs while the rig scans the
  // material, as a lab's would. Here the simulated scan keeps both cores busy, and the
  // calibration's stretches on one core fill what it leaves.
  std::future<Status> calibrated =
      std::async(std::launch::async, [&] { return args.calibrate ? Calibrate(args.out, stages) : Status::Ok(); });
  const Status scanned = ScanMaterial(args, rig, stages);
  const Status calibration = calibrated.get();
  LOOM_RETURN_IF_ERROR(scanned);
  LOOM_RETURN_IF_ERROR(calibration);
  return Reconstruct(args, stages);
}

Status GroundTruth(const DemoArguments& args, const std::string& rig, Stages* stages) {
  const fs::path out(args.out);
  sim::FastPathStackRequest request;
  request.size_px = args.size_px;
  request.out = out / "fast-path-stack.exr";
  request.truth = out / "truth.exr";
  const std::string command = "sim render --rig " + rig + " --object " + args.object + " --stack --preset " + args.preset +
                              " --truth " + request.truth.string() + " --out " + request.out.string() + SizeOption(args.size_px);
  return stages->Run("ground truth", command, [&]() -> Status {
    LOOM_ASSIGN_OR_RETURN(const LoadedRig loaded, LoadRig(rig, args.object));
    if (!loaded.sim) return InvalidArgumentError(rig, "not a simulated rig (it has no 'geometry:' section)");
    LOOM_ASSIGN_OR_RETURN(const scan::Preset preset, scan::LoadPreset(ResolvePresetPath(args.preset)));
    return sim::WriteFastPathStack(*loaded.sim->world->scene(), preset, request, std::cout);
  });
}

Status FitByMethod(const DemoArguments& args, const std::string& method, Stages* stages) {
  const fs::path out(args.out);
  fitting::FitRequest request;
  request.stack = out / "reconstruction" / "stack.exr";
  request.out = out / ("fit-" + method);
  request.method = method;
  request.models_dir = fs::path(LOOM_CONFIGS_DIR) / "models";
  std::map<std::string, ProgressBar> bars;
  request.options.progress = [&](const fitting::StackFitProgress& p) {
    bars.try_emplace(p.stage, p.stage, args.quiet).first->second.Update(p.done, p.total, p.stage);
  };
  const std::string command = "fit " + request.stack.string() + " --method " + method + " --out " + request.out.string();
  return stages->Run("fit " + method, command, [&]() -> Status {
    LOOM_ASSIGN_OR_RETURN(const fitting::FitDirectory fit, fitting::FitToDirectory(request, std::cerr));
    bars.clear();
    fit.Report(std::cout);
    return Status::Ok();
  });
}

Status EvaluateMethod(const DemoArguments& args, const std::string& rig, const std::string& method, Stages* stages) {
  const fs::path out(args.out);
  fitting::EvaluateRequest request;
  request.maps = out / ("fit-" + method) / "svbrdf.exr";
  request.stack = out / "reconstruction" / "stack.exr";
  request.reference = out / "truth.exr";
  request.out = out / ("report-" + method);
  request.title = args.object + " on " + rig + " (scan → calibrate → reconstruct → " + method + ")";
  const std::string command = "eval " + request.maps.string() + " --stack " + request.stack.string() + " --reference " +
                              request.reference.string() + " --out " + request.out.string() + " --title '" + request.title + "'";
  return stages->Run("evaluate " + method, command, [&]() -> Status {
    LOOM_ASSIGN_OR_RETURN(const fitting::EvaluatedDirectory evaluated, fitting::EvaluateToDirectory(request));
    evaluated.Report(std::cout);
    return Status::Ok();
  });
}

Status FitAndEvaluate(const DemoArguments& args, const std::string& rig, Stages* stages) {
  LOOM_RETURN_IF_ERROR(GroundTruth(args, rig, stages));
  for (const std::string& method : args.methods) {
    LOOM_RETURN_IF_ERROR(FitByMethod(args, method, stages));
    LOOM_RETURN_IF_ERROR(EvaluateMethod(args, rig, method, stages));
  }
  const fs::path out(args.out);
  fitting::ExportRequest request;
  request.maps = out / ("fit-" + args.methods.back()) / "svbrdf.exr";
  request.gltf = out / "gltf";
  request.axf = out / "material.axf";
  const std::string command =
      "export " + request.maps.string() + " --gltf " + request.gltf.string() + " --axf " + request.axf.string();
  return stages->Run("export", command, [&] { return fitting::ExportMaps(request, std::cout); });
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
  Stages stages;
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
