#include "core/reference_objects.h"

#include <array>
#include <cmath>

#include "core/srgb.h"

namespace loom {
namespace {

// The ColorChecker Classic in 8-bit sRGB (published averages), row-major, dark skin first.
constexpr std::array<std::array<int, 3>, ColourChartModel::kPatches> kChartSrgb = {{
    {115, 82, 68},   {194, 150, 130}, {98, 122, 157},  {87, 108, 67},   {133, 128, 177}, {103, 189, 170},
    {214, 126, 44},  {80, 91, 166},   {193, 90, 99},   {94, 60, 108},   {157, 188, 64},  {224, 163, 46},
    {56, 61, 150},   {70, 148, 73},   {175, 54, 60},   {231, 199, 31},  {187, 86, 149},  {8, 133, 161},
    {243, 243, 242}, {200, 200, 200}, {160, 160, 160}, {122, 122, 121}, {85, 85, 85},    {52, 52, 52},
}};

}  // namespace

Eigen::Vector2d ColourChartModel::PatchCentre(int patch) const {
  const int col = patch % kColumns, row = patch / kColumns;
  return {(col + 0.5 - kColumns / 2.0) * PitchMm(), (row + 0.5 - kRows / 2.0) * PitchMm()};
}

int ColourChartModel::PatchAt(double x_mm, double y_mm) const {
  const double gx = x_mm / PitchMm() + kColumns / 2.0;
  const double gy = y_mm / PitchMm() + kRows / 2.0;
  const int col = static_cast<int>(std::floor(gx));
  const int row = static_cast<int>(std::floor(gy));
  if (col < 0 || col >= kColumns || row < 0 || row >= kRows) return -1;
  const double half = 0.5 / 1.2;  // the patch's half-width in pitches
  if (std::abs(gx - col - 0.5) >= half || std::abs(gy - row - 0.5) >= half) return -1;
  return row * kColumns + col;
}

Eigen::Vector3d ColourChartModel::Albedo(int patch) {
  const auto& srgb = kChartSrgb.at(patch);
  return {SrgbDecode(srgb[0] / 255.0), SrgbDecode(srgb[1] / 255.0), SrgbDecode(srgb[2] / 255.0)};
}

}  // namespace loom
