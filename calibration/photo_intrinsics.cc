#include "calibration/photo_intrinsics.h"

#include <glob.h>

#include <algorithm>
#include <iomanip>

namespace loom::calibration {
namespace {

Result<std::vector<std::string>> ExpandGlob(const std::string& pattern) {
  glob_t matches{};
  const int code = ::glob(pattern.c_str(), 0, nullptr, &matches);
  std::vector<std::string> files(matches.gl_pathv, matches.gl_pathv + matches.gl_pathc);
  ::globfree(&matches);
  if (code == GLOB_NOMATCH || files.empty()) return NotFoundError("images '" + pattern + "'", "matches no file");
  if (code != 0) return IoError("images '" + pattern + "'", "cannot be expanded");
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

Result<CameraCalibration> CalibrateFromPhotos(const std::string& pattern, const BoardSpec& board, const std::string& name) {
  LOOM_ASSIGN_OR_RETURN(const std::vector<std::string> files, ExpandGlob(pattern));
  LOOM_ASSIGN_OR_RETURN(const DetectedViews detected, DetectBoardInFiles(files, board));
  LOOM_ASSIGN_OR_RETURN(const Intrinsics intrinsics, CalibrateIntrinsics(board, detected.views, detected.width, detected.height));
  CameraCalibration result{name, intrinsics, std::nullopt, {}, detected.skipped, pattern, board.ToString()};
  for (const BoardView& view : detected.views) result.view_sources.push_back(view.source);
  return result;
}

void ReportPhotoCalibration(std::ostream& out, const CameraCalibration& calibration) {
  const Intrinsics& intrinsics = calibration.intrinsics;
  out << std::fixed << std::setprecision(3) << "board found in " << calibration.view_sources.size() << " of "
      << calibration.view_sources.size() + calibration.skipped.size() << " images; RMS reprojection error " << intrinsics.rms_px
      << " px\nfx " << intrinsics.K(0, 0) << "  fy " << intrinsics.K(1, 1) << "  cx " << intrinsics.K(0, 2) << "  cy "
      << intrinsics.K(1, 2) << " px;  k1 " << intrinsics.distortion[0] << "  k2 " << intrinsics.distortion[1] << "\n";
  const auto worst = std::max_element(intrinsics.per_view_rms_px.begin(), intrinsics.per_view_rms_px.end());
  if (worst != intrinsics.per_view_rms_px.end()) {
    out << "worst view: " << calibration.view_sources[worst - intrinsics.per_view_rms_px.begin()] << " (" << *worst << " px)\n";
  }
  out << std::defaultfloat;
}

}  // namespace loom::calibration
