#include "sim/test_materials.h"

#include <cmath>

#include "core/check.h"
#include "fitting/model/svbrdf_maps.h"
#include "sim/internal/grid_check.h"

namespace loom::sim {
namespace {

void ThrowIfBad(const GridOptions& grid) {
  const Status checked = grid.Check();
  LOOM_CHECK(checked.ok()) << checked.ToString();
}

fitting::WardParams<double> Lambertian(const Eigen::Vector3d& albedo) {
  fitting::WardParams<double> p;
  p.a_d = albedo;
  p.a_s = Eigen::Vector3d::Zero();
  p.sigma_x = p.sigma_y = 0.3;
  return p;
}

// A flat material whose albedo is given per point (sample-frame mm).
template <typename AlbedoAt>
Material FlatLambertian(const std::string& name, const GridOptions& grid, AlbedoAt albedo_at) {
  ThrowIfBad(grid);
  Material m;
  m.name = name;
  m.pixel_mm = grid.pixel_mm;
  m.maps = fitting::MakeSvbrdfImage(grid.width_px, grid.height_px, /*with_height=*/true);
  for (int y = 0; y < grid.height_px; ++y) {
    for (int x = 0; x < grid.width_px; ++x) {
      const double cx = (x + 0.5 - grid.width_px / 2.0) * grid.pixel_mm;
      const double cy = (y + 0.5 - grid.height_px / 2.0) * grid.pixel_mm;
      fitting::SetParams(m.maps, x, y, Lambertian(albedo_at(cx, cy)));
    }
  }
  m.provenance = {{"loom.generator", std::string("sim::" + name)}};
  return m;
}

}  // namespace

Status GridOptions::Check() const {
  std::vector<std::string> problems;
  internal::AddGridProblems(width_px, height_px, pixel_mm, /*zero_is_default=*/false, problems);
  return ProblemsStatus("GridOptions", problems);
}

Material UniformMaterial(const std::string& name, const fitting::WardParams<double>& params, const GridOptions& grid) {
  ThrowIfBad(grid);
  Material m;
  m.name = name;
  m.pixel_mm = grid.pixel_mm;
  m.maps = fitting::MakeSvbrdfImage(grid.width_px, grid.height_px, /*with_height=*/true);
  for (int y = 0; y < grid.height_px; ++y) {
    for (int x = 0; x < grid.width_px; ++x) fitting::SetParams(m.maps, x, y, params);
  }
  m.provenance = {{"loom.generator", std::string("sim::UniformMaterial")}};
  return m;
}

Material WhiteTile(const GridOptions& grid, double albedo) {
  return FlatLambertian("white tile", grid, [&](double, double) -> Eigen::Vector3d { return Eigen::Vector3d::Constant(albedo); });
}

Material WhiteTileOnSpacer(const GridOptions& grid, double albedo, double spacer_mm) {
  Material m = WhiteTile(grid, albedo);
  m.name = "white tile on its spacer";
  const int height = *m.maps.FindChannel("height");
  for (int y = 0; y < m.height(); ++y) {
    for (int x = 0; x < m.width(); ++x) m.maps.at(height, y, x) = static_cast<float>(spacer_mm);
  }
  m.provenance = {{"loom.generator", std::string("sim::WhiteTileOnSpacer")}, {"loom.spacer_mm", std::to_string(spacer_mm)}};
  return m;
}

Material Chessboard(int inner_cols, int inner_rows, double square_mm, const GridOptions& grid) {
  const double half_w = (inner_cols + 1) * square_mm / 2;
  const double half_h = (inner_rows + 1) * square_mm / 2;
  Material m = FlatLambertian("chessboard", grid, [&](double x, double y) -> Eigen::Vector3d {
    if (std::abs(x) >= half_w || std::abs(y) >= half_h) return Eigen::Vector3d::Constant(0.85);
    const int col = static_cast<int>(std::floor((x + half_w) / square_mm));
    const int row = static_cast<int>(std::floor((y + half_h) / square_mm));
    return Eigen::Vector3d::Constant((col + row) % 2 == 0 ? 0.04 : 0.85);
  });
  m.provenance["loom.board"] =
      "chessboard:" + std::to_string(inner_cols) + "x" + std::to_string(inner_rows) + ":" + std::to_string(square_mm);
  return m;
}

Material CalibrationTarget(const CalibrationTargetModel& target) {
  constexpr double kPixelMm = 0.1;
  const double cos_tilt = std::cos(DegToRad(target.tilt_deg));
  const double half_u = (target.inner_cols + 1) * target.square_mm / 2;
  const double half_v = (target.inner_rows + 1) * target.square_mm / 2;
  // The board and a white margin of one square, in the sample frame's x and y.
  const double half_x = half_u + target.square_mm, half_y = (half_v + target.square_mm) * cos_tilt;
  const int size = 2 * static_cast<int>(std::ceil(std::max(half_x, half_y) / kPixelMm));
  const GridOptions grid{size, size, kPixelMm};
  Material m = FlatLambertian("calibration target", grid, [&](double x, double y) -> Eigen::Vector3d {
    const double u = x, v = y / cos_tilt;  // board coordinates of the point
    if (std::abs(u) >= half_u || std::abs(v) >= half_v) return Eigen::Vector3d::Constant(0.85);
    const int col = static_cast<int>(std::floor((u + half_u) / target.square_mm));
    const int row = static_cast<int>(std::floor((v + half_v) / target.square_mm));
    return Eigen::Vector3d::Constant((col + row) % 2 == 0 ? 0.04 : 0.85);
  });
  const int height_channel = *m.maps.ChannelIndex(fitting::kHeightChannel);
  const double slope = std::tan(DegToRad(target.tilt_deg));
  for (int y = 0; y < size; ++y) {
    const double cy = (y + 0.5 - size / 2.0) * kPixelMm;
    for (int x = 0; x < size; ++x) m.maps.at(height_channel, y, x) = static_cast<float>(target.centre_height_mm + cy * slope);
  }
  m.provenance["loom.geometric_blur_mm"] = 0.2;  // a plane: the blur only rounds its edges
  return m;
}

Material ChromeSphere(const LightProbeModel& probe) {
  constexpr double kPixelMm = 0.05;
  const double r = probe.radius_mm;
  const int size = 2 * static_cast<int>(std::ceil(r / kPixelMm)) + 4;
  fitting::WardParams<double> chrome;
  chrome.a_d = Eigen::Vector3d::Constant(0.005);
  chrome.a_s = Eigen::Vector3d::Constant(0.9);
  chrome.sigma_x = chrome.sigma_y = 0.05;
  chrome.f0 = 1;
  const GridOptions grid{size, size, kPixelMm};
  Material m =
      FlatLambertian("chrome sphere", grid, [](double, double) -> Eigen::Vector3d { return Eigen::Vector3d::Constant(0.02); });
  const int height_channel = *m.maps.ChannelIndex(fitting::kHeightChannel);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const double cx = (x + 0.5 - size / 2.0) * kPixelMm, cy = (y + 0.5 - size / 2.0) * kPixelMm;
      const double rho2 = cx * cx + cy * cy;
      if (rho2 >= r * r) continue;
      fitting::SetParams(m.maps, x, y, chrome);
      m.maps.at(height_channel, y, x) = static_cast<float>(r + std::sqrt(r * r - rho2));
    }
  }
  m.provenance["loom.geometric_blur_mm"] = kPixelMm;  // the sphere's own normals
  return m;
}

Material ColourChart(const ColourChartModel& chart, const GridOptions& grid) {
  return FlatLambertian("colour chart", grid, [&](double x, double y) -> Eigen::Vector3d {
    const int patch = chart.PatchAt(x, y);
    return patch < 0 ? Eigen::Vector3d::Constant(ColourChartModel::kGapAlbedo) : ColourChartModel::Albedo(patch);
  });
}

}  // namespace loom::sim
