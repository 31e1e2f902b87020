#pragma once
// A scanner's description: geometry, light sources and sensors of a TAC7-like rig, read from the
// `geometry:` section of a rig YAML (configs/rig/*.yaml). Nominal for a real rig (calibration
// refines it), exact for the simulated one; plans use it to know what there is to capture. Frames: `rig` has its origin at
// the centre of the turntable's top surface, z up, mm; `sample` turns with the turntable
// (rig_from_sample = rotation about the turntable axis by the table angle); cameras follow
// OpenCV (x right, y down, z forward).
//
// Light units: an LED's radiant intensity is `intensity` (radiance units · mm² per sr) at 1000 mA
// along its axis, falling off as cos^n of the angle to its axis; irradiance = I / d² · cos. A
// camera turns radiance into electrons with `sensitivity` (electrons per radiance unit per
// second of exposure at the image centre), less vignetting towards the corners.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/geometry.h"
#include "core/image.h"
#include "core/reference_objects.h"

namespace loom {

struct SensorModel {
  int adc_bits = 12;
  double dark_offset_dn = 64;
  double read_noise_e = 2.5;   // electrons rms
  double full_well_e = 10000;  // electrons
  double sensitivity = 2.0e6;  // electrons per (radiance unit · s)
  double vignetting = 0.25;    // relative loss at the image corner: 1 − v (r / r_corner)²
  // Per pixel, the response over that quadratic model's (channel "flat", sensor-sized; 1 where
  // nothing measured it), from radiometric calibration's white reference or a simulated rig's
  // as-built optics; null: the quadratic model alone.
  std::shared_ptr<const Image> flat_field;
  // Electrons per DN at unit gain: the ADC range spans the full well above the dark offset.
  double ElectronsPerDn() const { return full_well_e / ((1 << adc_bits) - 1 - dark_offset_dn); }
  // Vignetting: the response at pixel (x, y) of a width × height image relative to the centre's,
  // times the flat field's value at the nearest pixel when there is one.
  double RelativeResponse(double x, double y, int width, int height) const;
  // The quadratic model alone.
  double QuadraticResponse(double x, double y, int width, int height) const;
};

struct CameraModel {
  std::string name;
  int width = 0;
  int height = 0;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();                               // pixels
  Eigen::Matrix<double, 5, 1> distortion = Eigen::Matrix<double, 5, 1>::Zero();  // k1 k2 p1 p2 k3
  Rigid3d cam_from_rig = Rigid3d::Identity();
  SensorModel sensor;

  Eigen::Vector3d CentreInRig() const { return cam_from_rig.inverse().translation(); }
  // Pixel (subpixel coordinates, pixel centres at integers) of a point in the camera frame,
  // with lens distortion (OpenCV's model). False if behind the camera.
  bool Project(const Eigen::Vector3d& p_in_cam, Eigen::Vector2d* pixel) const;
  // Unit ray direction in the camera frame through a pixel (inverts the distortion).
  Eigen::Vector3d Unproject(const Eigen::Vector2d& pixel) const;
};

struct LedModel {
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // rig frame
  Eigen::Vector3d axis = -Eigen::Vector3d::UnitZ();       // unit, where the LED points
  double intensity = 1.0e6;
  double falloff_exponent = 1.0;
  // Radiant intensity towards `point_in_rig` at `current_ma`.
  double IntensityTowards(const Eigen::Vector3d& point_in_rig, double current_ma) const;
};

// A slot of a filter wheel: a band-pass filter, or the open position (no filter) through which
// the LED behind the wheel lights monochrome steps.
struct FilterModel {
  bool open = false;
  double center_nm = 550;
  double fwhm_nm = 30;
  double peak_transmission = 0.9;
  // What a camera records of an RGB albedo through this slot, as radiometric calibration
  // measured it on the colour chart (calibration/radiometry.h); unset: the spectral model's.
  std::optional<Eigen::Vector3d> measured_weights;

  static FilterModel Open() {
    FilterModel slot;
    slot.open = true;
    return slot;
  }
  static FilterModel BandPass(double center_nm, double fwhm_nm) {
    FilterModel slot;
    slot.center_nm = center_nm;
    slot.fwhm_nm = fwhm_nm;
    return slot;
  }
};

struct FilterWheelModel {
  std::string name;
  int led = 0;  // the LED it sits in front of
  std::vector<FilterModel> filters;
  // The first open slot, if the wheel has one.
  std::optional<int> OpenSlot() const;
};

// The linear light: an LED strip on an arm that sweeps over the sample. The arm turns about
// `sweep_axis` (through the rig origin); the strip lies parallel to that axis at
// `arm_radius_mm` from it, emitting towards it. The carriage position of the hal LinearLight
// (0..travel_mm) maps linearly onto the arm angle start_deg..end_deg (0° = the zenith).
struct LinearLightModel {
  double arm_radius_mm = 500;
  double strip_length_mm = 300;
  Eigen::Vector3d sweep_axis = Eigen::Vector3d::UnitY();
  double start_deg = -70;
  double end_deg = 70;
  double travel_mm = 400;
  double intensity_per_mm = 4000;  // radiant intensity per mm of strip, along its normal, at full power
  double falloff_exponent = 1;
  int segments = 32;  // point sources the strip is integrated with
  // Relative output along the strip at equally spaced points from its −sweep_axis end to its
  // +sweep_axis end, linear in between (its LEDs are not all equally bright); empty: even.
  std::vector<double> profile;

  // Centre of the strip and its emitting direction (unit, towards the sweep axis) at a carriage position.
  Eigen::Vector3d StripCentre(double position_mm) const;
  Eigen::Vector3d StripNormal(double position_mm) const;
  // The profile at `along_mm` from the strip's centre along sweep_axis (1 without a profile).
  double ProfileAt(double along_mm) const;
  // Why `profile` cannot be a strip's (empty or 2 to 64 values, each in (0, 10]), or "" if it can.
  static std::string ProfileProblem(const std::vector<double>& profile);
  // Where the k-th of the `segments` point sources sits, from the strip's centre along sweep_axis.
  double SegmentOffsetMm(int k) const { return (k + 0.5) * strip_length_mm / segments - strip_length_mm / 2; }
};

// The structured-light projector: a pinhole that emits the pattern it shows; a white pixel's
// radiant intensity is `max_intensity`.
struct ProjectorModel {
  int width = 0;
  int height = 0;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Rigid3d proj_from_rig = Rigid3d::Identity();
  double max_intensity = 2.0e5;
};

struct TurntableModel {
  Eigen::Vector3d axis_point_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_direction = Eigen::Vector3d::UnitZ();
  Rigid3d RigFromSample(double angle_deg) const;
};

// The geometric calibration target: a chessboard on a wedge, placed on the turntable with its
// centre on the axis and its rows along the sample frame's x. The tilt makes the views at
// several turntable angles differ in orientation (a flat board turned about its own normal
// constrains no focal length). Board frame: origin at the board's centre, x along its rows,
// y up the slope, z out of the board.
struct CalibrationTargetModel {
  int inner_cols = 7;  // inner corners along a row
  int inner_rows = 5;
  double square_mm = 2.5;
  double tilt_deg = 23.07;  // of the board against the turntable, rising towards +y
  double centre_height_mm = 8;
  Rigid3d SampleFromBoard() const;
  // Inner corner (c, r) in the board frame, row-major.
  std::vector<Eigen::Vector3d> CornersInBoard() const;
};

struct RigModel {
  std::string name;
  double sample_holder_diameter_mm = 140;
  std::vector<CameraModel> cameras;
  std::vector<LedModel> leds;
  std::vector<FilterWheelModel> filter_wheels;
  TurntableModel turntable;
  std::optional<LinearLightModel> linear_light;
  std::optional<ProjectorModel> projector;
  std::optional<CalibrationTargetModel> calibration_target;
  WhiteReferenceModel white_reference;
  ColourChartModel colour_chart;
  std::optional<LightProbeModel> light_probe;  // without one, a calibration scan cannot find the lights

  const CameraModel* FindCamera(const std::string& name) const;
  // The wheel in front of `led`, or nullptr.
  const FilterWheelModel* WheelOfLed(int led) const;
};

// Reads the `geometry:` mapping (problems are recorded in its document).
RigModel ReadRigModel(const ConfigNode& geometry);

}  // namespace loom
