#pragma once
// The reference objects of a calibration scan (besides the geometric target), as the rig YAML's
// `geometry:` describes them:
//
//   white_reference: {albedo: 0.95, spacer_mm: 30}   # a diffuse tile (Spectralon-like), its certified
//                                     # albedo; spacer_mm: a calibration also shows the projector's
//                                     # patterns on it lying on the table and raised on a spacer
//                                     # about this thick (its focal length; absent: no spacer)
//   colour_chart: {patch_mm: 3.2}     # a ColorChecker Classic of 6 × 4 patches, centred
//   light_probe: {radius_mm: 10}      # a chrome sphere (for the lights' directions)
//
// The tile and the chart lie flat on the turntable, centred on its axis; the sphere rests on the
// turntable, its centre on the axis at radius_mm above the table. The chart's patches are squares of
// patch_mm on a pitch of 1.2 × patch_mm (20 % gaps, on black), row-major from the top left
// (−x, −y in the sample frame), dark skin first; their albedos are the chart's published
// sRGB averages, linearised.

#include <Eigen/Core>

namespace loom {

struct WhiteReferenceModel {
  double albedo = 0.95;
  double spacer_mm = 0;  // 0: none
};

struct LightProbeModel {
  double radius_mm = 10;
  Eigen::Vector3d CentreInSample() const { return {0, 0, radius_mm}; }
};

struct ColourChartModel {
  static constexpr int kColumns = 6;
  static constexpr int kRows = 4;
  static constexpr int kPatches = kColumns * kRows;
  static constexpr double kGapAlbedo = 0.02;
  double patch_mm = 3.2;

  double PitchMm() const { return 1.2 * patch_mm; }
  // Centre of patch i (sample frame, mm, on the chart's plane).
  Eigen::Vector2d PatchCentre(int patch) const;
  // The patch a point lies on, or −1 in a gap or off the chart.
  int PatchAt(double x_mm, double y_mm) const;
  // Linear-sRGB albedo of patch i.
  static Eigen::Vector3d Albedo(int patch);
};

}  // namespace loom
