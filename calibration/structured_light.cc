#include "calibration/structured_light.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

#include "core/geometry.h"
#include "scan/patterns.h"

namespace loom::calibration {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

Result<const Image*> Pattern(const std::map<std::string, Image>& patterns, const std::string& name, const Image* like) {
  const auto it = patterns.find(name);
  if (it == patterns.end()) return NotFoundError("structured-light pattern '" + name + "'", "no image of it in the scan");
  if (like != nullptr && (it->second.width() != like->width() || it->second.height() != like->height())) {
    return InvalidArgumentError("structured-light pattern '" + name + "'",
                                "its image differs in size from the white reference's");
  }
  return &it->second;
}

double Percentile(std::vector<float> values, double q) {
  if (values.empty()) return 0;
  const auto nth = values.begin() + static_cast<std::ptrdiff_t>(q * (values.size() - 1));
  std::nth_element(values.begin(), nth, values.end());
  return *nth;
}

// Fills NaN heights with the mean of their known 8-neighbours, ring by ring from the known ones.
int FillHoles(std::vector<float>& heights, int width, int height) {
  int filled = 0;
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<float> next = heights;
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        if (!std::isnan(heights[y * width + x])) continue;
        double sum = 0;
        int count = 0;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const int nx = x + dx;
            const int ny = y + dy;
            if (nx < 0 || ny < 0 || nx >= width || ny >= height || std::isnan(heights[ny * width + nx])) continue;
            sum += heights[ny * width + nx];
            ++count;
          }
        }
        if (count > 0) {
          next[y * width + x] = static_cast<float>(sum / count);
          ++filled;
          changed = true;
        }
      }
    }
    heights.swap(next);
  }
  return filled;
}

}  // namespace

Status DecodeOptions::Check() const {
  std::vector<std::string> problems;
  if (projector_width < 2 || projector_width > kMaxProjectorWidth) {
    problems.push_back("projector_width must be in [2, " + std::to_string(kMaxProjectorWidth) + "]");
  }
  if (phase_steps < 3) problems.push_back("phase_steps must be ≥ 3 (a phase needs three shifts)");
  if (!(min_contrast >= 0 && min_contrast < 1)) problems.push_back("min_contrast must be in [0, 1)");
  return ProblemsStatus("DecodeOptions", problems);
}

Result<Image> DecodeProjectorColumns(const std::map<std::string, Image>& patterns, const DecodeOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  LOOM_ASSIGN_OR_RETURN(const Image* white, Pattern(patterns, "white", nullptr));
  LOOM_ASSIGN_OR_RETURN(const Image* black, Pattern(patterns, "black", white));
  const int bits = scan::GrayCodeBits(options.projector_width);
  std::vector<std::pair<const Image*, const Image*>> gray;
  for (int b = 0; b < bits; ++b) {
    LOOM_ASSIGN_OR_RETURN(const Image* on, Pattern(patterns, scan::GrayPatternName(b, false), white));
    LOOM_ASSIGN_OR_RETURN(const Image* off, Pattern(patterns, scan::GrayPatternName(b, true), white));
    gray.emplace_back(on, off);
  }
  std::vector<const Image*> phase;
  for (int k = 0; k < options.phase_steps; ++k) {
    LOOM_ASSIGN_OR_RETURN(const Image* shifted, Pattern(patterns, "phase_x_" + std::to_string(k), white));
    phase.push_back(shifted);
  }
  const int w = white->width();
  const int h = white->height();
  std::vector<float> contrast(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) contrast[y * w + x] = white->at(0, y, x) - black->at(0, y, x);
  }
  std::vector<float> finite;
  for (float c : contrast) {
    if (std::isfinite(c)) finite.push_back(c);
  }
  const double min_contrast = options.min_contrast * Percentile(finite, 0.9);
  const double period = scan::kPhasePeriodColumns;
  Image columns(w, h, {"column"});
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float& out = columns.at(0, y, x);
      out = kNaN;
      if (!(contrast[y * w + x] > min_contrast)) continue;
      int binary = 0;
      int bit_of_binary = 0;
      for (int b = 0; b < bits; ++b) {  // Gray → binary, most significant bit first
        const int gray_bit = gray[b].first->at(0, y, x) > gray[b].second->at(0, y, x) ? 1 : 0;
        bit_of_binary ^= gray_bit;
        binary = (binary << 1) | bit_of_binary;
      }
      double s = 0;
      double c = 0;
      for (int k = 0; k < options.phase_steps; ++k) {
        const double shift = 2 * kPi * k / options.phase_steps;
        s += phase[k]->at(0, y, x) * std::sin(shift);
        c += phase[k]->at(0, y, x) * std::cos(shift);
      }
      const double theta = std::atan2(-s, c);
      const double in_period = period * (theta / (2 * kPi) - std::floor(theta / (2 * kPi)));  // [0, period)
      // The period whose phase position lies nearest the Gray column.
      const double periods = std::round((binary - in_period) / period);
      out = static_cast<float>(periods * period + in_period);
    }
  }
  return columns;
}

Result<TriangulatedHeights> TriangulateHeights(const Image& columns, const CameraModel& camera, const ProjectorModel& projector,
                                               const TurntableModel& turntable, double turntable_deg, const HeightmapGrid& grid) {
  if (grid.width <= 0 || grid.height <= 0 || grid.pixel_mm <= 0) {
    return InvalidArgumentError("heightmap grid", "needs a positive size and pixel size");
  }
  const Rigid3d rig_from_sample = turntable.RigFromSample(turntable_deg);
  const Rigid3d cam_from_sample = camera.cam_from_rig * rig_from_sample;
  const Rigid3d proj_from_sample = projector.proj_from_rig * rig_from_sample;
  // f(h): projector column of the surface point minus the column decoded where the camera sees it.
  const auto mismatch = [&](double x, double y, double h) -> std::optional<double> {
    const Eigen::Vector3d p(x, y, h);
    Eigen::Vector2d pixel;
    if (!camera.Project(cam_from_sample * p, &pixel)) return std::nullopt;
    const float decoded = SampleBilinear(columns, 0, pixel.x(), pixel.y());
    const Eigen::Vector3d q = proj_from_sample * p;
    if (std::isnan(decoded) || q.z() <= 0) return std::nullopt;
    return (projector.K * (q / q.z())).x() - decoded;
  };
  TriangulatedHeights result;
  result.heights_mm.assign(static_cast<size_t>(grid.width) * grid.height, kNaN);
  int decoded = 0;  // grid pixels where the camera decoded a column at all
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const double x = (i + 0.5 - grid.width / 2.0) * grid.pixel_mm;
      const double y = (j + 0.5 - grid.height / 2.0) * grid.pixel_mm;
      double h0 = 0;
      double h1 = 0.5;
      std::optional<double> f0 = mismatch(x, y, h0);
      std::optional<double> f1 = mismatch(x, y, h1);
      if (f0 || f1) ++decoded;
      for (int iteration = 0; iteration < 30 && f0 && f1 && *f1 != *f0; ++iteration) {
        const double h2 = std::clamp(h1 - *f1 * (h1 - h0) / (*f1 - *f0), grid.min_height_mm, grid.max_height_mm);
        h0 = h1;
        f0 = f1;
        h1 = h2;
        f1 = mismatch(x, y, h1);
        if (f1 && std::abs(*f1) < 1e-4) break;
      }
      if (f1 && std::abs(*f1) < 0.05) result.heights_mm[j * grid.width + i] = static_cast<float>(h1);
    }
  }
  result.filled = FillHoles(result.heights_mm, grid.width, grid.height);
  if (std::isnan(result.heights_mm.front())) {
    const std::string where = "structured light of camera '" + camera.name + "'";
    if (decoded == 0)
      return FailedPreconditionError(where, "no projector column decoded on the heightmap grid (pattern not seen?)");
    // Columns were seen but no height in range fits them: the geometry, not the patterns.
    std::ostringstream message;
    message << "the projector columns decoded at " << decoded << " of " << grid.width * grid.height
            << " heightmap grid pixels fit no height in [" << grid.min_height_mm << ", " << grid.max_height_mm
            << "] mm: the projector or the camera is not where the rig model puts it (recalibrate: loom calibrate "
               "geometry), or the sample lies outside that height range";
    return FailedPreconditionError(where, message.str());
  }
  return result;
}

}  // namespace loom::calibration
