#pragma once
// Has the rig drifted from its stored calibration? From a fresh calibration scan's target views:
//  - the stored cameras, held as they are, must explain the new views: only the target's
//    placement (offset and yaw, geometry.h's TargetPlacement) is fitted. A fresh calibration
//    of the same views (CalibrateRigGeometry, starting from the stored one) shows the capture's
//    own noise; what the stored model leaves beyond it, √(stored² − fresh²) per camera, is the
//    drift in pixels. That is what reconstruction depends on, and it is decisive;
//  - the fresh calibration also says what moved: each camera's rotation and centre against the
//    stored pose, and the turntable's axis as each camera sees it (tilt, and shift across the
//    camera's view). At narrow fields these carry the calibration's own uncertainty: a nearly
//    orthographic camera can turn and shift across its view together (geometry.h). Measured on
//    a tac7-mini-like rig with 0.25 px corner noise: up to 0.25° of axis tilt in the top camera
//    from noise alone, hence the default tilt threshold of 0.5°.
// Radiometry: a fresh radiometric calibration (radiometry.h) of the new scan's white reference,
// over a rig that carries the stored one (ApplyRadiometry), gives each light's and each
// camera's change directly. LED positions likewise, from the light probe. Both are measured on
// the fresh geometry (and the radiometry on the fresh LED positions), so that a camera or an LED
// that moved does not read as a light that changed. The reference camera anchors the scale, so a change of its own
// sensitivity shows as every light changing alike.
//
// The projector likewise: a fresh calibration of its columns at the new target views, starting
// from the stored one, says how far its columns moved (projector.h's column_change_px).
//
// Thresholds live in the rig YAML, as its optional top-level section
//   recalibration: {reprojection_px: 0.25, turntable_axis_deg: 0.5, turntable_axis_mm: 1.0,
//                   intensity_percent: 3, led_position_mm: 8, projector_column_px: 0.15,
//                   linear_light_deg: 0.5}

#include <optional>
#include <string>
#include <vector>

#include "calibration/geometry.h"
#include "calibration/light_positions.h"
#include "calibration/projector.h"
#include "calibration/radiometry.h"
#include "core/config.h"

namespace loom::calibration {

struct DriftThresholds {
  double reprojection_px = 0.25;  // drift: the stored model's RMS beyond the capture's noise
  double turntable_axis_deg = 0.5;
  double turntable_axis_mm = 1.0;
  double intensity_percent = 3;  // a light's intensity or a camera's sensitivity, against the stored
  double led_position_mm = 8;    // an LED's position: camera pose errors alone move it up to ~5 mm (light_positions.h)
  // The projector's columns at the target's corners, fresh against stored: twice what separates
  // a calibration from the truth in the sample volume (0.074 px, projector.h). On tac7-mini a
  // column is ~1.5 mm of height (0.66 mm per column at the sample, planes tilted 24°).
  double projector_column_px = 0.15;
  // The linear light's arm angle (start or end of its sweep): the sphere measures it to ~0.05°
  // (light_positions.h); 0.5° moves the strip 4 mm at tac7-mini's 450 mm arm.
  double linear_light_deg = 0.5;
};

// Reads a `recalibration:` section (strict keys; absent keys keep their defaults).
DriftThresholds ReadDriftThresholds(const ConfigNode& node);

struct CameraDrift {
  std::string name;
  int views = 0;
  double stored_rms_px = 0;  // the stored calibration on the new views
  double fresh_rms_px = 0;   // a fresh calibration on the same views: the capture's own noise
  double drift_px = 0;       // √(stored² − fresh²), 0 when the stored model does as well
  double rotation_deg = 0;   // fresh pose against stored, with the target's yaw taken out
  double centre_mm = 0;
  double axis_tilt_deg = 0;           // the turntable axis in this camera's frame, fresh against stored
  double axis_shift_mm = 0;           // its origin, across the camera's view
  std::vector<std::string> exceeded;  // what crossed its threshold, with the values
};

struct DriftReport {
  TargetPlacement placement;  // where the stored calibration sees the new target
  double stored_rms_px = 0;   // over every camera
  double fresh_rms_px = 0;
  std::vector<CameraDrift> cameras;
  std::vector<scan::ViewId> rejected;  // misdetected views, judged by neither
  bool recalibrate = false;            // some camera exceeded a threshold
  RigGeometry fresh;                   // the fresh calibration of the new views (ApplyGeometry)
};

// `stored`: the rig with the stored calibration applied (ApplyCameraCalibrations), in the
// turntable's frame. An error when a camera saw too few views (named, as in geometry.h).
Result<DriftReport> MeasureDrift(const RigModel& stored, const CalibrationTargetModel& target,
                                 const std::vector<TargetView>& views, const DriftThresholds& thresholds);

// What changed against a stored calibration, item by item, and what crossed its threshold.
struct Changes {
  std::string unit;                                    // "%", "mm"
  std::vector<std::pair<std::string, double>> change;  // "led 3", "cam1 sensitivity" → in `unit`
  std::vector<std::string> exceeded;                   // with the values, for people
};

// `fresh`: CalibrateRadiometry of the new scan over the rig with the stored radiometry applied.
Changes MeasureRadiometricDrift(const Radiometry& fresh, const DriftThresholds& thresholds);
// `fresh`: CalibrateLightPositions of the new scan over the rig with the stored positions applied.
Changes MeasureLightPositionDrift(const LightPositions& fresh, const DriftThresholds& thresholds);
// The linear light's sweep in `fresh` (as above) against the stored one: empty when not measured.
std::optional<Changes> MeasureLinearLightDrift(const LightPositions& fresh, const DriftThresholds& thresholds);
// `fresh`: CalibrateProjector of the new scan's target columns with the stored projector as prior.
Changes MeasureProjectorDrift(const ProjectorCalibration& fresh, const DriftThresholds& thresholds);

}  // namespace loom::calibration
