#pragma once
// Where the LEDs are, from a chrome sphere (the rig YAML's light_probe: its radius; it rests on
// the turntable, centred on the axis) lit by one LED at a time, seen by every camera:
//  1. the highlight: the radiance-weighted centroid of the pixels near the brightest one, above
//     a tenth of its value;
//  2. the camera's ray through it meets the sphere at P, normal N; the view direction mirrored
//     about N points at the LED: the LED lies on the ray P + s·L;
//  3. one sphere fixes directions, not distances: the rays of all cameras start millimetres
//     apart and point at an LED half a metre away. Each ray is followed to the rig's nominal
//     distance of that LED from the sphere's centre and the points are averaged; how far a
//     camera's ray misses the average (as an angle from its origin) is the residual. Distance errors change irradiance
//     as 1/d², which radiometric calibration, measured with these positions, takes up.
// Measured on the simulated tac7-mini: within 1.3 mm (0.11°) of the truth with exact cameras;
// 3.4-4.6 mm (0.3-0.4°) after loom calibrate geometry, whose camera poses carry 1-2 mm and
// 0.05-0.13° of their own error (geometry.h).
// The linear light, from the same sphere under the strip at several carriage positions: every
// point of the strip lies on the cylinder of the arm's radius about the sweep axis, at the arm's
// angle. Each view's mirrored ray (through the centroid of a piece of the strip's streak) is
// followed to that cylinder, which gives the arm's angle at that carriage position; a line
// through the angles gives the sweep's start and end angles. The arm's radius stays nominal,
// as the LEDs' distances do. Measured on the simulated tac7-mini with exact cameras, the arm
// turned 1.5°: start and end within 0.04° of the truth, views within 0.10° of the line.

#include <optional>
#include <string>
#include <vector>

#include "calibration/scan_radiance.h"
#include "core/rig_model.h"

namespace loom::calibration {

struct LightPosition {
  int led = 0;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // rig frame
  double change_deg = 0;                                  // the direction from the sphere against the rig's
  double change_mm = 0;                                   // the position against the rig's
  double residual_deg = 0;                                // the largest angle between a camera's ray and the position found
  int views = 0;
};

// The linear light's arm angle (about its sweep axis, 0 = zenith) is start_deg at carriage 0 and
// end_deg at travel_mm, linear in between.
struct LinearLightSweep {
  double start_deg = 0;
  double end_deg = 0;
  double change_deg = 0;    // the larger change of the two against the rig's
  double residual_deg = 0;  // the largest angle of a view from the fitted line
  int views = 0;
};

struct LightPositions {
  double probe_radius_mm = 0;
  std::vector<LightPosition> leds;
  std::optional<LinearLightSweep> linear_light;  // where the scan lit the sphere with the strip
};

// `views`: light-probe views of `rig` (its cameras calibrated), each lit by one LED or by the
// linear light alone. Every LED needs a view; the strip's views, at two carriage positions or
// more, give the sweep. A view whose highlight is missing or saturated is an error naming it.
Result<LightPositions> CalibrateLightPositions(const RigModel& rig, const std::vector<LitView>& views);

// The LEDs moved to the calibrated positions, keeping their axes; the linear light's sweep
// angles where they were measured.
void ApplyLightPositions(const LightPositions& positions, RigModel* rig);

// CALIB/light_positions.yaml (device: lights): written atomically, read strictly.
Status WriteLightPositions(const std::filesystem::path& directory, const LightPositions& positions, const std::string& from);
// Applies CALIB/light_positions.yaml when there is one; returns whether. A file for another
// number of LEDs names the file.
Result<bool> ApplyLightPositionCalibration(const std::filesystem::path& directory, RigModel* rig);

}  // namespace loom::calibration
