#include "sim/test_materials.h"

#include <array>
#include <cmath>

#include "fitting/model/svbrdf_maps.h"

namespace loom::sim {
namespace {

// The ColorChecker Classic in 8-bit sRGB (published averages), row-major, dark skin first.
constexpr std::array<std::array<int, 3>, 24> kChartSrgb = {{
    {115, 82, 68},   {194, 150, 130}, {98, 122, 157},  {87, 108, 67},   {133, 128, 177}, {103, 189, 170},
    {214, 126, 44},  {80, 91, 166},   {193, 90, 99},   {94, 60, 108},   {157, 188, 64},  {224, 163, 46},
    {56, 61, 150},   {70, 148, 73},   {175, 54, 60},   {231, 199, 31},  {187, 86, 149},  {8, 133, 161},
    {243, 243, 242}, {200, 200, 200}, {160, 160, 160}, {122, 122, 121}, {85, 85, 85},    {52, 52, 52},
}};

double SrgbToLinear(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

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

Material UniformMaterial(const std::string& name, const fitting::WardParams<double>& params, const GridOptions& grid) {
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

Material WhiteTile(const GridOptions& grid) {
  return FlatLambertian("white tile", grid, [](double, double) -> Eigen::Vector3d { return Eigen::Vector3d::Constant(0.95); });
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
  m.provenance["loom.board"] = "chessboard:" + std::to_string(inner_cols) + "x" + std::to_string(inner_rows) + ":" +
                               std::to_string(square_mm);
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

Eigen::Vector3d ColourChartAlbedo(int patch) {
  const auto& srgb = kChartSrgb.at(patch);
  return {SrgbToLinear(srgb[0] / 255.0), SrgbToLinear(srgb[1] / 255.0), SrgbToLinear(srgb[2] / 255.0)};
}

Material ColourChart(double patch_mm, const GridOptions& grid) {
  const double cell = patch_mm * 1.2;
  return FlatLambertian("colour chart", grid, [&](double x, double y) -> Eigen::Vector3d {
    const double gx = x / cell + 3;  // 6 columns
    const double gy = y / cell + 2;  // 4 rows
    const int col = static_cast<int>(std::floor(gx));
    const int row = static_cast<int>(std::floor(gy));
    const bool inside_patch = std::abs(gx - col - 0.5) < 0.5 / 1.2 && std::abs(gy - row - 0.5) < 0.5 / 1.2;
    if (col < 0 || col >= 6 || row < 0 || row >= 4 || !inside_patch) return Eigen::Vector3d::Constant(0.02);
    return ColourChartAlbedo(row * 6 + col);
  });
}

}  // namespace loom::sim
