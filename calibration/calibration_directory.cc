#include "calibration/calibration_directory.h"

#include "calibration/calibration_yaml.h"
#include "calibration/light_positions.h"
#include "calibration/projector.h"
#include "calibration/radiometry_yaml.h"

namespace loom::calibration {
namespace {

constexpr char kNominal[] = "nominal (the scan's rig YAML)";

}  // namespace

nlohmann::json AppliedCalibration::ToJson() const {
  const auto state = [](bool calibrated) { return calibrated ? "calibrated" : kNominal; };
  return {{"calibrated_cameras", cameras},
          {"led_positions", state(led_positions)},
          {"projector", state(projector)},
          {"radiometry", state(radiometry.has_value())}};
}

Result<AppliedCalibration> CalibrationDirectory::ApplyGeometry(RigModel* rig) const {
  AppliedCalibration applied;
  LOOM_ASSIGN_OR_RETURN(applied.cameras, ApplyCameraCalibrations(path_, rig));
  LOOM_ASSIGN_OR_RETURN(applied.led_positions, ApplyLightPositionCalibration(path_, rig));
  return applied;
}

Result<AppliedCalibration> CalibrationDirectory::Apply(RigModel* rig) const {
  LOOM_ASSIGN_OR_RETURN(AppliedCalibration applied, ApplyGeometry(rig));
  LOOM_ASSIGN_OR_RETURN(applied.projector, ApplyProjectorCalibration(path_, rig));
  LOOM_ASSIGN_OR_RETURN(applied.radiometry, ApplyRadiometryCalibration(path_, rig));
  return applied;
}

}  // namespace loom::calibration
