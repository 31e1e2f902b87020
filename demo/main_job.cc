#include "demo/main_job.h"

#include <chrono>
#include <future>
#include <iomanip>
#include <mutex>
#include <ostream>
#include <sstream>

#include "calibration/scan_calibration.h"
#include "core/duration.h"
#include "core/file_io.h"
#include "core/output_directory.h"
#include "core/progress_bar.h"
#include "core/rig_file.h"
#include "core/version.h"
#include "fitting/fit_directory.h"
#include "fitting/report/evaluate_directory.h"
#include "fitting/report/export_maps.h"
#include "fitting/report/report.h"
#include "reconstruction/scan_reconstruction.h"
#include "scan/plan.h"
#include "sim/fast_path_stack.h"
#include "sim/rig_scene.h"

namespace loom::demo {
namespace {

namespace fs = std::filesystem;

struct StageTime {
  std::string name;
  double seconds = 0;
};

// Runs the stages and keeps how long each took. Two stages may run at once, on two threads.
class Stages {
 public:
  explicit Stages(std::ostream& report) : report_(report) {}

  // `command`: the loom command line that does the same by hand, printed before the stage runs.
  Status Run(const std::string& name, const std::string& command, const std::function<Status()>& stage) {
    {
      std::lock_guard lock(mutex_);
      report_ << "\n== " << name << ": loom " << command << std::endl;
    }
    const auto start = std::chrono::steady_clock::now();
    const Status done = stage();
    std::lock_guard lock(mutex_);
    times_.push_back({name, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()});
    report_.flush();
    if (!done.ok()) return done.WithContext("demo stage '" + name + "'");
    return Status::Ok();
  }

  const std::vector<StageTime>& times() const { return times_; }

 private:
  std::ostream& report_;
  std::mutex mutex_;
  std::vector<StageTime> times_;
};

// What every stage needs: the request, where to report, and the stages run so far.
struct Job {
  const MainJobRequest& request;
  const ScanOnRig& scan_on_rig;
  std::ostream& report;
  std::ostream& notes;
  Stages stages;

  fs::path Out(const std::string& name) const { return request.out / name; }
};

std::string SizeOption(int size_px) { return size_px > 0 ? " --size " + std::to_string(size_px) : ""; }

Status ScanMaterial(Job& job) {
  const MainJobRequest& r = job.request;
  scan::ScanRequest scan;
  scan.rig_path = r.rig.string();
  scan.preset = r.preset;
  scan.object = r.object;
  scan.crop_mm = r.crop_mm;
  scan.out = job.Out("scan");
  scan.quiet = r.quiet;
  std::ostringstream command;
  command << "scan --rig " << scan.rig_path << " --preset " << r.preset << " --object " << r.object << " --out "
          << scan.out.string();
  if (r.crop_mm > 0) command << " --crop-mm " << r.crop_mm;
  return job.stages.Run("material scan", command.str(), [&] { return job.scan_on_rig(scan); });
}

Status CalibrationScan(Job& job) {
  // A rig whose material scan reads a crop has sensors too large to read whole for every view
  // of a calibration object.
  scan::ScanRequest scan;
  scan.rig_path = job.request.rig.string();
  scan.calibration = true;
  scan.object_windows = job.request.crop_mm > 0;
  scan.out = job.Out("calibration-scan");
  scan.quiet = job.request.quiet;
  const std::string command = "scan --rig " + scan.rig_path + " --calibration --out " + scan.out.string() +
                              (scan.object_windows ? " --object-windows" : "");
  return job.stages.Run("calibration scan", command, [&] { return job.scan_on_rig(scan); });
}

// Geometry, then radiometry, from the calibration scan.
Status Calibrate(Job& job) {
  const fs::path scan = job.Out("calibration-scan"), calib = job.Out("calib");
  LOOM_RETURN_IF_ERROR(
      job.stages.Run("calibrate geometry", "calibrate geometry " + scan.string() + " --out " + calib.string(), [&]() -> Status {
        LOOM_ASSIGN_OR_RETURN(const calibration::GeometryCalibration geometry,
                              calibration::CalibrateGeometryToDirectory(scan, calib));
        geometry.Report(job.report);
        return Status::Ok();
      }));
  return job.stages.Run("calibrate radiometry", "calibrate radiometry " + scan.string() + " --calib " + calib.string(),
                        [&]() -> Status {
                          LOOM_ASSIGN_OR_RETURN(const calibration::RadiometryCalibration radiometry,
                                                calibration::CalibrateRadiometryFromScan(scan, calib, ""));
                          for (const std::string& note : radiometry.notes) job.notes << note << "\n";
                          LOOM_RETURN_IF_ERROR(radiometry.Write(calib));
                          radiometry.Report(job.report);
                          return Status::Ok();
                        });
}

Status Reconstruct(Job& job) {
  const MainJobRequest& r = job.request;
  reconstruction::ReconstructOptions options;
  if (r.size_px > 0) options.width_px = options.height_px = r.size_px;
  const fs::path calib = r.calibrate ? job.Out("calib") : fs::path();
  const std::string command = "reconstruct " + job.Out("scan").string() + " --out " + job.Out("reconstruction").string() +
                              (r.calibrate ? " --calib " + calib.string() : "") + SizeOption(r.size_px);
  return job.stages.Run("reconstruct", command, [&]() -> Status {
    StageProgressBars bars("reconstruct: ", r.quiet);
    const auto progress = [&](const reconstruction::ReconstructProgress& p) {
      bars.Update(p.stage, p.done, p.total, p.stage == "heightmap" ? "steps" : "views");
    };
    LOOM_ASSIGN_OR_RETURN(
        const reconstruction::ReconstructedDirectory written,
        reconstruction::ReconstructToDirectory(job.Out("scan"), calib, options, job.Out("reconstruction"), progress));
    bars.Close();
    for (const std::string& note : written.scanned.notes) job.notes << "note: " << note << "\n";
    written.Report(job.report);
    return Status::Ok();
  });
}

Status CalibrateAndScan(Job& job) {
  const bool calibrate = job.request.calibrate;
  if (calibrate) LOOM_RETURN_IF_ERROR(CalibrationScan(job));
  // Calibrating needs the calibration scan, not the rig: it runs while the rig scans the
  // material, as a lab's would. Here the simulated scan keeps both cores busy, and the
  // calibration's stretches on one core fill what it leaves.
  std::future<Status> calibrated = std::async(std::launch::async, [&] { return calibrate ? Calibrate(job) : Status::Ok(); });
  const Status scanned = ScanMaterial(job);
  const Status calibration = calibrated.get();
  LOOM_RETURN_IF_ERROR(scanned);
  LOOM_RETURN_IF_ERROR(calibration);
  return Reconstruct(job);
}

// The fast-path stack's truth maps on the reconstruction's grid, from the simulated rig's scene.
Status GroundTruth(Job& job) {
  const MainJobRequest& r = job.request;
  sim::FastPathStackRequest truth;
  truth.size_px = r.size_px;
  truth.out = job.Out("fast-path-stack.exr");
  truth.truth = job.Out("truth.exr");
  const std::string command = "sim render --rig " + r.rig.string() + " --object " + r.object + " --stack --preset " + r.preset +
                              " --truth " + truth.truth.string() + " --out " + truth.out.string() + SizeOption(r.size_px);
  return job.stages.Run("ground truth", command, [&]() -> Status {
    LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Load(r.rig));
    if (!file.Has("geometry")) return InvalidArgumentError(r.rig.string(), "not a simulated rig (it has no 'geometry:' section)");
    LOOM_ASSIGN_OR_RETURN(const RigModel model, file.Model());
    LOOM_ASSIGN_OR_RETURN(const sim::RigScene rig, sim::MakeRigScene(file, model, r.object));
    LOOM_ASSIGN_OR_RETURN(const scan::Preset preset, scan::LoadPreset(r.preset_file));
    return sim::WriteFastPathStack(*rig.scene, preset, truth, job.report);
  });
}

Status FitByMethod(Job& job, const std::string& method) {
  fitting::FitRequest fit;
  fit.stack = job.Out("reconstruction") / "stack.exr";
  fit.out = job.Out("fit-" + method);
  fit.method = method;
  fit.models_dir = job.request.models_dir;
  StageProgressBars bars("", job.request.quiet);
  fit.options.progress = [&](const fitting::StackFitProgress& p) { bars.Update(p.stage, p.done, p.total, p.stage); };
  const std::string command = "fit " + fit.stack.string() + " --method " + method + " --out " + fit.out.string();
  return job.stages.Run("fit " + method, command, [&]() -> Status {
    LOOM_ASSIGN_OR_RETURN(const fitting::FitDirectory fitted, fitting::FitToDirectory(fit, job.notes));
    bars.Close();
    fitted.Report(job.report);
    return Status::Ok();
  });
}

Status EvaluateMethod(Job& job, const std::string& method) {
  fitting::EvaluateRequest evaluate;
  evaluate.maps = job.Out("fit-" + method) / "svbrdf.exr";
  evaluate.stack = job.Out("reconstruction") / "stack.exr";
  evaluate.reference = job.Out("truth.exr");
  evaluate.out = job.Out("report-" + method);
  evaluate.title = job.request.object + " on " + job.request.rig.string() + " (scan → calibrate → reconstruct → " + method + ")";
  const std::string command = "eval " + evaluate.maps.string() + " --stack " + evaluate.stack.string() + " --reference " +
                              evaluate.reference.string() + " --out " + evaluate.out.string() + " --title '" + evaluate.title +
                              "'";
  return job.stages.Run("evaluate " + method, command, [&]() -> Status {
    LOOM_ASSIGN_OR_RETURN(const fitting::EvaluatedDirectory evaluated, fitting::EvaluateToDirectory(evaluate));
    evaluated.Report(job.report);
    return Status::Ok();
  });
}

Status FitAndEvaluate(Job& job) {
  LOOM_RETURN_IF_ERROR(GroundTruth(job));
  for (const std::string& method : job.request.methods) {
    LOOM_RETURN_IF_ERROR(FitByMethod(job, method));
    LOOM_RETURN_IF_ERROR(EvaluateMethod(job, method));
  }
  fitting::ExportRequest exported;
  exported.maps = job.Out("fit-" + job.request.methods.back()) / "svbrdf.exr";
  exported.gltf = job.Out("gltf");
  exported.axf = job.Out("material.axf");
  const std::string command =
      "export " + exported.maps.string() + " --gltf " + exported.gltf.string() + " --axf " + exported.axf.string();
  return job.stages.Run("export", command, [&] { return fitting::ExportMaps(exported, job.report); });
}

Result<nlohmann::ordered_json> ReadJson(const fs::path& path) {
  LOOM_ASSIGN_OR_RETURN(const std::string text, ReadFile(path));
  nlohmann::ordered_json json = nlohmann::ordered_json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded()) return InvalidArgumentError(path.string(), "not JSON");
  return json;
}

// The evaluations and stage times as one document.
Result<nlohmann::ordered_json> Summarise(const Job& job, double wall_seconds) {
  const MainJobRequest& r = job.request;
  nlohmann::ordered_json summary = {
      {"rig", r.rig.string()}, {"object", r.object}, {"preset", r.preset}, {"loom_version", std::string(VersionWithCommit())}};
  summary["calibration_rms_px"] = nullptr;  // none: the rig YAML's geometry
  if (r.calibrate) {
    LOOM_ASSIGN_OR_RETURN(const nlohmann::ordered_json geometry, ReadJson(job.Out("calib") / "geometry.json"));
    summary["calibration_rms_px"] = geometry["rms_px"];
  }
  if (r.crop_mm > 0) summary["crop_mm"] = r.crop_mm;
  for (const StageTime& stage : job.stages.times()) summary["stage_seconds"][stage.name] = stage.seconds;
  summary["wall_seconds"] = wall_seconds;  // less than the stages' sum: calibrating ran during the material scan
  for (const std::string& method : r.methods) {
    LOOM_ASSIGN_OR_RETURN(nlohmann::ordered_json evaluation, ReadJson(job.Out("report-" + method) / "summary.json"));
    evaluation["report"] = (job.Out("report-" + method) / "index.html").string();
    summary["methods"][method] = std::move(evaluation);
  }
  return summary;
}

}  // namespace

Result<nlohmann::ordered_json> RunMainJob(MainJobRequest request, const ScanOnRig& scan_on_rig, std::ostream& report,
                                          std::ostream& notes) {
  // A job that reconstructs a crop scans only that crop: on tac7's 2048 × 1536 sensors a whole
  // material scan takes hours on 2 cores, the 12.8 mm that size 64 reconstructs a few minutes.
  if (request.crop_mm == 0 && request.size_px > 0)
    request.crop_mm = request.size_px * reconstruction::ReconstructOptions{}.pixel_mm;
  if (request.methods.empty()) return InvalidArgumentError("--methods", "names no fit method");
  LOOM_RETURN_IF_ERROR(CheckDirectoryOutputPath(request.out, "--out"));
  if (fs::exists(request.out) && !fs::is_empty(request.out)) {
    return AlreadyExistsError(request.out.string(),
                              "is not empty: the demo writes a fresh directory (remove it, or pick another --out)");
  }
  Job job{request, scan_on_rig, report, notes, Stages(report)};
  const auto start = std::chrono::steady_clock::now();
  LOOM_RETURN_IF_ERROR(CalibrateAndScan(job));
  LOOM_RETURN_IF_ERROR(FitAndEvaluate(job));
  const double wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  LOOM_ASSIGN_OR_RETURN(const nlohmann::ordered_json summary, Summarise(job, wall_seconds));
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(request.out / "summary.json", summary.dump(2) + "\n"));
  return summary;
}

void PrintMainJobSummary(const nlohmann::ordered_json& summary, std::ostream& out) {
  out << "\n== summary: " << summary["object"].get<std::string>() << " on " << summary["rig"].get<std::string>() << ", preset "
      << summary["preset"].get<std::string>() << "; ";
  if (summary["calibration_rms_px"].is_null()) {
    out << "not calibrated (the rig YAML's geometry)\n";
  } else {
    out << "camera calibration RMS " << std::fixed << std::setprecision(3) << summary["calibration_rms_px"].get<double>()
        << " px\n";
  }
  fitting::PrintEvaluationTable(out, summary["methods"]);
  out << "\ntime per stage (calibrating during the material scan):";
  for (const auto& [stage, seconds] : summary["stage_seconds"].items()) {
    out << "\n  " << std::left << std::setw(22) << stage << std::right << FormatDuration(seconds.get<double>());
  }
  out << "\n  " << std::left << std::setw(22) << "total (wall clock)" << std::right
      << FormatDuration(summary["wall_seconds"].get<double>()) << "\n";
}

}  // namespace loom::demo
