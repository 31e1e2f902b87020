#include "fitting/model/label.h"

#include <algorithm>
#include <cmath>

namespace loom::fitting {
namespace {

// Smallest n_z a decoded shading normal may have (≈ 89.9° from the geometric normal).
constexpr double kMinNormalZ = 1e-3;

}  // namespace

double EncodeSigma(double sigma) { return (std::log(sigma + 0.01) - std::log(0.01)) / (std::log(1.01) - std::log(0.01)); }

double DecodeSigma(double encoded) { return 0.01 * (std::pow(101.0, encoded) - 1.0); }

Label EncodeLabel(const WardParams<double>& p) {
  return {p.a_d.x(),
          p.a_d.y(),
          p.a_d.z(),
          p.a_s.x(),
          p.a_s.y(),
          p.a_s.z(),
          p.n_s.x(),
          p.n_s.y(),
          p.n_s.z(),
          EncodeSigma(p.sigma_x),
          EncodeSigma(p.sigma_y),
          std::cos(2 * p.alpha),
          std::sin(2 * p.alpha),
          p.f0};
}

WardParams<double> DecodeLabel(const Label& label) {
  WardParams<double> p;
  p.a_d = Eigen::Vector3d(label[0], label[1], label[2]).cwiseMax(0.0);
  p.a_s = Eigen::Vector3d(label[3], label[4], label[5]).cwiseMax(0.0);
  Eigen::Vector3d n(label[6], label[7], std::max(label[8], kMinNormalZ));
  p.n_s = n.normalized();
  p.sigma_x = std::max(DecodeSigma(std::max(label[9], 0.0)), kSigmaFloor);
  p.sigma_y = std::max(DecodeSigma(std::max(label[10], 0.0)), kSigmaFloor);
  // atan2 normalises the pair implicitly and returns (−π, π], so α ∈ (−π/2, π/2].
  // A (0, 0) pair carries no direction; atan2 gives α = 0, as good as any.
  p.alpha = 0.5 * std::atan2(label[12], label[11]);
  p.f0 = std::clamp(label[13], 0.0, 1.0);
  return p;
}

}  // namespace loom::fitting
