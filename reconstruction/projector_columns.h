#pragma once
// The projector columns a scan's structured-light steps encode (structured_light.h), decoded per
// camera and turntable angle; and, for the projector's calibration (calibration/projector.h),
// the decoded column at each corner of the calibration target where the calibrated cameras see
// it. The target's black squares are too dark to decode, so a corner's column comes from a
// plane fitted to the decodable pixels around it (its white squares).

#include <vector>

#include "calibration/geometry.h"
#include "calibration/projector.h"
#include "calibration/scan_radiance.h"
#include "core/image.h"

namespace loom::reconstruction {

// The turntable angles at which the scan's plan has structured-light steps, in plan order.
std::vector<double> StructuredLightAngles(const acquisition::Plan& plan);

// The structured-light steps at `turntable_deg`, decoded in `camera`: channel "column" (NaN
// where undecodable). A missing pattern, or too few phase patterns, is an error naming it.
Result<Image> DecodeScanColumns(const calibration::ScanRadiance& scan, const CameraModel& camera, double turntable_deg);

// Every camera, every structured-light angle: the target's corners (placed as loom calibrate
// geometry found it; the scan's rig carries that calibration) with their decoded columns.
Result<std::vector<calibration::ProjectorCorrespondence>> TargetCornerColumns(const calibration::ScanRadiance& scan,
                                                                              const CalibrationTargetModel& target,
                                                                              const calibration::TargetPlacement& placement);

}  // namespace loom::reconstruction
