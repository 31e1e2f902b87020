#include "fitting/solve/internal/normal_frame.h"

#include <Eigen/Geometry>

namespace loom::fitting::internal {

Eigen::Matrix3d TurnOntoZ(const Eigen::Vector3d& normal) {
  return Eigen::Quaterniond::FromTwoVectors(normal.normalized(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

void TurnObservations(const Eigen::Matrix3d& turn, std::vector<PixelObservation>& observations) {
  for (PixelObservation& o : observations) {
    o.v_local = turn * o.v_local;
    for (LightSample& light : o.lights) light.l_local = turn * light.l_local;
  }
}

WardParams<double> TurnedBack(const Eigen::Matrix3d& turn, WardParams<double> params) {
  params.n_s = (turn.transpose() * params.n_s).normalized();
  return params;
}

}  // namespace loom::fitting::internal
