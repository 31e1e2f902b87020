// loom calibrate: turn calibration captures into calibration files (calibration/).
//   intrinsics  one camera from a folder of photos of a chessboard (recalibration in the field)
#include <glob.h>

#include <algorithm>
#include <iomanip>
#include <iostream>

#include "apps/command.h"
#include "calibration/calibration_yaml.h"
#include "calibration/intrinsics.h"

namespace loom::apps {
namespace {

Result<std::vector<std::string>> ExpandGlob(const std::string& pattern) {
  glob_t matches{};
  const int code = ::glob(pattern.c_str(), 0, nullptr, &matches);
  std::vector<std::string> files(matches.gl_pathv, matches.gl_pathv + matches.gl_pathc);
  ::globfree(&matches);
  if (code == GLOB_NOMATCH || files.empty()) return NotFoundError("--images '" + pattern + "'", "matches no file");
  if (code != 0) return IoError("--images '" + pattern + "'", "cannot be expanded");
  std::sort(files.begin(), files.end());
  return files;
}

Status CalibrateFromPhotos(const std::string& images, const std::string& board_text, const std::string& name,
                  const std::string& out) {
  LOOM_ASSIGN_OR_RETURN(const calibration::BoardSpec board, calibration::ParseBoardSpec(board_text));
  LOOM_ASSIGN_OR_RETURN(const std::vector<std::string> files, ExpandGlob(images));
  std::cerr << "looking for " << board.ToString() << " in " << files.size() << " images\n";
  LOOM_ASSIGN_OR_RETURN(const calibration::DetectedViews detected, calibration::DetectBoardInFiles(files, board));
  LOOM_ASSIGN_OR_RETURN(const calibration::Intrinsics intrinsics,
                        calibration::CalibrateIntrinsics(board, detected.views, detected.width, detected.height));
  calibration::CameraCalibration result{name, intrinsics, std::nullopt, {}, detected.skipped, images, board.ToString()};
  for (const calibration::BoardView& view : detected.views) result.view_sources.push_back(view.source);
  LOOM_RETURN_IF_ERROR(calibration::WriteCameraCalibration(out, result));
  std::cout << std::fixed << std::setprecision(3) << "board found in " << detected.views.size() << " of " << files.size()
            << " images; RMS reprojection error " << intrinsics.rms_px << " px\n"
            << "fx " << intrinsics.K(0, 0) << "  fy " << intrinsics.K(1, 1) << "  cx " << intrinsics.K(0, 2) << "  cy "
            << intrinsics.K(1, 2) << " px;  k1 " << intrinsics.distortion[0] << "  k2 " << intrinsics.distortion[1]
            << "\nworst view: ";
  const auto worst = std::max_element(intrinsics.per_view_rms_px.begin(), intrinsics.per_view_rms_px.end());
  std::cout << result.view_sources[worst - intrinsics.per_view_rms_px.begin()] << " (" << *worst << " px)\n"
            << "written: " << out << "\n";
  return Status::Ok();
}

}  // namespace

int RunCalibrate(int argc, char** argv) {
  CLI::App app("Calibrate cameras, lights and radiometry from calibration captures", "loom calibrate");
  AddCommonOptions(app);
  app.require_subcommand(1);
  std::string images, board = "chessboard:9x6:25", name = "camera", out;
  CLI::App* intrinsics = app.add_subcommand(
      "intrinsics", "One camera's intrinsics and distortion from photos of a chessboard (e.g. after a lens change)");
  intrinsics->add_option("--images", images, "Glob of the photos, quoted: 'DIR/*.jpg'")->required();
  intrinsics->add_option("--board", board, "chessboard:COLSxROWS:SQUARE_MM, inner corners (default chessboard:9x6:25)");
  intrinsics->add_option("--name", name, "The camera's name in the rig (default: camera)");
  intrinsics->add_option("--out", out, "Calibration YAML to write")->required();
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  Status done;
  if (*intrinsics) done = CalibrateFromPhotos(images, board, name, out);
  return done.ok() ? kExitOk : ReportFailure(done);
}

}  // namespace loom::apps
