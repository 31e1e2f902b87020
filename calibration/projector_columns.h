#pragma once
// The projector columns a scan's structured-light steps encode (structured_light.h), decoded per
// camera, object and turntable angle; and, for the projector's calibration
// (calibration/projector.h), the decoded column at each corner of the calibration target where
// the calibrated cameras see it, and the rays of the camera pixels that saw the white tile under
// the patterns. The target's black squares are too dark to decode, so a corner's column comes
// from a plane fitted to the decodable pixels around it (its white squares).

#include <string>
#include <vector>

#include "calibration/geometry.h"
#include "calibration/projector.h"
#include "calibration/scan_radiance.h"
#include "core/image.h"

namespace loom::calibration {

// The turntable angles at which the scan's plan has structured-light steps on `object`, in plan
// order.
std::vector<double> StructuredLightAngles(const scan::Plan& plan, scan::ScanObject object);

// The structured-light steps on `object` at `turntable_deg`, decoded in `camera`: channel
// "column" (NaN where undecodable). A missing pattern, or too few phase patterns, is an error
// naming it.
Result<Image> DecodeScanColumns(const ScanRadiance& scan, const CameraModel& camera, scan::ScanObject object,
                                double turntable_deg);

// Every camera, every structured-light angle: the target's corners (placed as loom calibrate
// geometry found it; the scan's rig carries that calibration) with their decoded columns.
Result<std::vector<ProjectorCorrespondence>> TargetCornerColumns(const ScanRadiance& scan, const CalibrationTargetModel& target,
                                                                 const TargetPlacement& placement);

// The flat boards of a calibration scan under the patterns — the white tile on the table and on
// its spacer (scan/plan.h), at their nominal heights; none when the scan has no spacer
// step — with every camera's decoded pixels on each (at most max_rays_per_camera, on a regular
// grid of pixels) as rays in the rig frame (the scan's rig carries the calibration).
Result<std::vector<FlatBoardView>> FlatBoardRays(const ScanRadiance& scan, int max_rays_per_camera = 4000);

}  // namespace loom::calibration
