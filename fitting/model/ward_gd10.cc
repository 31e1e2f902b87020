#include "fitting/model/ward_gd10.h"

#include <sstream>
#include <utility>

namespace loom::fitting {
namespace {

void CheckRange(std::vector<std::string>& problems, const std::string& name, double value, double low, double high) {
  if (std::isfinite(value) && value >= low && value <= high) return;
  std::ostringstream out;
  out << name << " = " << value << " is outside [" << low << ", " << high << "]";
  problems.push_back(out.str());
}

}  // namespace

std::vector<std::string> CheckWardParams(const WardParams<double>& p) {
  std::vector<std::string> problems;
  const char* rgb[] = {"R", "G", "B"};
  for (int i = 0; i < 3; ++i) {
    CheckRange(problems, std::string("a_d.") + rgb[i], p.a_d[i], 0.0, 1.0);
    CheckRange(problems, std::string("a_s.") + rgb[i], p.a_s[i], 0.0, 1.0);
  }
  CheckRange(problems, "sigma_x", p.sigma_x, kMinSigma, kMaxSigma);
  CheckRange(problems, "sigma_y", p.sigma_y, kMinSigma, kMaxSigma);
  if (!(p.alpha > -kPi / 2 && p.alpha <= kPi / 2)) {
    std::ostringstream out;
    out << "alpha = " << p.alpha << " is outside (-pi/2, pi/2]";
    problems.push_back(out.str());
  }
  CheckRange(problems, "f0", p.f0, 0.0, 1.0);
  if (!(std::abs(p.n_s.norm() - 1.0) < 1e-6 && p.n_s.z() > 0.0)) {
    std::ostringstream out;
    out << "n_s = (" << p.n_s.transpose() << ") is not a unit vector with z > 0";
    problems.push_back(out.str());
  }
  return problems;
}

WardParams<double> WithSigmaXLarger(WardParams<double> params) {
  if (params.sigma_x < params.sigma_y) {
    std::swap(params.sigma_x, params.sigma_y);
    params.alpha += kPi / 2;
  }
  return params;
}

double AngleBetweenLobes(double alpha, double other) { return std::abs(std::remainder(alpha - other, kPi)); }

}  // namespace loom::fitting
