#pragma once
// Radiometric calibration: how much light each LED and the linear light give, how each camera
// turns radiance into counts across its image, and what each colour filter lets through — from a
// calibration scan's white-reference and colour-chart steps, on top of a geometric calibration
// (which camera pixel looks at which point of the turntable).
//
// White reference: a diffuse tile of known albedo ρ (the rig YAML's white_reference), flat on the
// turntable, lit by one light at a time. At every camera pixel on the tile, the radiance the scan
// recorded (converted with the rig's sensor model, scan_radiance.h) is divided by what the rig's
// light model predicts, ρ/π · Σ I(p)/d² · cos θ. The ratio factors as
//   light_scale[l] · camera_scale[c] · flat[c](x, y)
// flat[c] is the sensor's vignetting model, 1 − v (r / r_corner)², fitted per camera by linear
// least squares on the ratio images (each normalised by its median, averaged over the lights);
// its residual says how well that model holds. What it leaves per pixel on the tile (lens
// vignetting that is not quadratic, dust, a decentred optical axis) is the per-pixel flat field,
// smoothed over flat_smoothing_px against the pixels' noise and feathered to 1 beyond the tile:
// the tile stands where samples lie, so that is where it is measured and needed. One per camera:
// the cameras are monochrome and the filters sit in front of LEDs, not lenses, so a filter
// changes no camera's flat field. The scales are medians. Only their product is
// observable: the reference camera (the top view unless chosen) keeps its sensitivity and the
// lights carry the rest, which is what reflectance needs (radiance over irradiance).
// The angular falloff of an LED is not observable this way: the tile subtends a few degrees from
// a light half a metre away, over which cos^n changes less than the noise. It stays nominal;
// the calibration reports the angle the tile subtends.
//
// Linear light: its white-reference view, the camera's flat field and the view's scale taken
// out, also gives the strip's profile along its length. Each tile pixel's ratio is Σ_k P_k w_k,
// w_k the share of the pixel's predicted irradiance coming from the stretch of strip around knot
// k (hat functions over the strip's point sources): linear least squares for the P_k, with a
// penalty on the profile's curvature. A tile point sees the whole strip, weighted by distance:
// the tile's extent along the strip makes the profile's level and slope observable, its shape
// far beyond the tile much less so (the penalty keeps it straight there). That is also where it
// matters least: a sample's highlights come from the strip near its mirror points, within a
// tile's size of the middle. The LED-lit views alone give the flat field.
//
// Colour chart (the rig YAML's colour_chart): each band-pass filter f in front of its LED. Per
// patch p, the chart's radiance over the white reference's under the same LED (open slot), at
// the same camera pixels, cancels light and camera alike: q = (w_f · a_p) / ρ. The filter's
// colour weights w_f (what the cameras record of an RGB albedo, core/spectra.h) are the least-
// squares fit over the 24 patches and every camera; each wheel's colour matrix, the pseudo-
// inverse of its filters' weights, turns its filter readings into linear sRGB. Its error is that
// of the chart's albedos recovered through it.
//
// Linearity: every white-reference bracket's readings against the merged radiance
// (hdr_merge.h's MeasureLinearity), per camera.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calibration/scan_radiance.h"
#include "core/rig_model.h"

namespace loom::calibration {

struct RadiometryOptions {
  std::string reference_camera;  // keeps its sensitivity; empty: the camera looking most nearly straight down
  int edge_px = 3;               // tile and patch edges left out: their pixels mix two albedos
  double flat_smoothing_px = 2;  // Gaussian σ of the per-pixel flat field over the tile (0: none)
  int strip_profile_knots = 9;   // points of the linear light's profile along its strip
  Status Check() const;          // every problem, naming the field
};

struct CameraRadiometry {
  std::string name;
  double black_dn = 0;  // from the dark step
  double read_noise_dn = 0;
  double sensitivity = 0;                   // electrons per (radiance unit · s) at the image centre
  double sensitivity_change = 1;            // calibrated over the rig's
  double vignetting = 0;                    // v of 1 − v (r / r_corner)²
  double flat_field_residual = 0;           // rms relative misfit of that model over the tile
  std::shared_ptr<const Image> flat_field;  // per pixel over that model (SensorModel::flat_field)
  double flat_field_max = 0;                // its largest departure from 1 on the tile
  int tile_pixels = 0;                      // pixels that saw the tile (one view)
  double linearity_deviation = 0;           // worst |reading / (radiance · t) − 1| of an exposure, over the tile
  double linearity_max_dn = 0;              // the highest mean reading it was measured at
};

struct LightRadiometry {
  std::string name;          // "led 3", "linear light"
  int led = -1;              // −1: the linear light
  double intensity = 0;      // LedModel::intensity, or LinearLightModel::intensity_per_mm
  double change = 1;         // calibrated over the rig's
  double camera_spread = 0;  // relative spread of the scale between cameras
  // The linear light only: its output along the strip (LinearLightModel::profile), fitted on the
  // white reference; empty for an LED.
  std::vector<double> profile;
};

struct FilterRadiometry {
  std::string wheel;
  int slot = 0;
  double center_nm = 0;
  Eigen::Vector3d weights = Eigen::Vector3d::Zero();          // measured
  Eigen::Vector3d nominal_weights = Eigen::Vector3d::Zero();  // the rig's spectral model
  double fit_residual = 0;                                    // rms relative misfit over the patches
};

struct WheelColour {
  std::string wheel;
  std::vector<int> slots;         // band-pass slots, the colour matrix's columns
  Eigen::MatrixXd colour_matrix;  // 3 × slots: filter readings (albedo units) → linear sRGB
  double chart_rms = 0;           // rms albedo error of the chart's patches recovered through it
  double chart_max = 0;           // the worst channel of the worst patch
};

struct Radiometry {
  std::string reference_camera;
  double white_albedo = 0;
  double tile_subtends_deg = 0;  // the widest angle the tile spans from a light (falloff)
  std::vector<CameraRadiometry> cameras;
  std::vector<LightRadiometry> lights;
  std::vector<FilterRadiometry> filters;
  std::vector<WheelColour> wheels;
};

// The core: white-reference and colour-chart views of `rig` (its geometry calibrated) → the
// radiometry. Every light and camera needs a white-reference view; a camera that sees too little
// of the tile, or a filter without chart views, is an error naming it.
Result<Radiometry> FitRadiometry(const RigModel& rig, const std::vector<LitView>& white, const std::vector<LitView>& chart,
                                 const RadiometryOptions& options);

// From a calibration scan: reads its views (the rig given to `scan` must carry the geometric
// calibration) and adds the dark level and linearity of every camera.
Result<Radiometry> CalibrateRadiometry(const ScanRadiance& scan, const RadiometryOptions& options);

// The calibrated values over a rig's: LED and linear-light intensities, camera sensitivity and
// vignetting, filters' measured colour weights.
void ApplyRadiometry(const Radiometry& radiometry, RigModel* rig);

}  // namespace loom::calibration
