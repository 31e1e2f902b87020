#include "sim/reflectance.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace loom::sim {
namespace {

// GGX's (Trowbridge–Reitz) normal distribution at cos θ_h, roughness a.
double GgxDistribution(double cos_h, double a) {
  const double a2 = a * a;
  const double d = cos_h * cos_h * (a2 - 1) + 1;
  return a2 / (kPi * d * d);
}

// Smith's masking for GGX at cos θ (> 0).
double GgxMasking(double cos_theta, double a) {
  return 2 * cos_theta / (cos_theta + std::sqrt(a * a + (1 - a * a) * cos_theta * cos_theta));
}

// 1 − m (1 − cos θ⊥): θ⊥ the angle of w from n in the plane across fibres along t.
double FibreMasking(const Eigen::Vector3d& w, const Eigen::Vector3d& n, const Eigen::Vector3d& t, double m) {
  const Eigen::Vector3d across = w - w.dot(t) * t;
  const double length = across.norm();
  const double cos_across = length > 1e-12 ? std::max(0.0, across.dot(n) / length) : 1.0;
  return 1 - m * (1 - cos_across);
}

}  // namespace

Result<std::optional<BeyondLayout>> FindBeyondChannels(const Image& maps) {
  BeyondLayout layout;
  int found = 0;
  const char* missing = nullptr;
  for (size_t i = 0; i < kBeyondChannels.size(); ++i) {
    const std::optional<int> c = maps.FindChannel(kBeyondChannels[i]);
    if (c) {
      layout.channel[i] = *c;
      ++found;
    } else if (!missing) {
      missing = kBeyondChannels[i];
    }
  }
  if (found == 0) return std::optional<BeyondLayout>();
  if (missing) return InvalidArgumentError("material maps", std::string("has some beyond.* channels but not ") + missing);
  return std::optional<BeyondLayout>(layout);
}

BeyondGd10 GetBeyond(const Image& maps, const BeyondLayout& layout, int x, int y) {
  const auto value = [&](int i) { return static_cast<double>(maps.at(layout.channel[i], y, x)); };
  BeyondGd10 beyond;
  beyond.coat = Eigen::Vector3d(value(0), value(1), value(2));
  beyond.coat_roughness = value(3);
  beyond.fibre_masking = value(4);
  beyond.meso_deg = value(5);
  return beyond;
}

BeyondLayout AddBeyondChannels(Image& maps) {
  BeyondLayout layout;
  for (size_t i = 0; i < kBeyondChannels.size(); ++i) layout.channel[i] = maps.AddChannel(kBeyondChannels[i]);
  return layout;
}

void SetBeyond(Image& maps, const BeyondLayout& layout, int x, int y, const BeyondGd10& beyond) {
  const double values[] = {beyond.coat.x(),       beyond.coat.y(),      beyond.coat.z(),
                           beyond.coat_roughness, beyond.fibre_masking, beyond.meso_deg};
  for (size_t i = 0; i < kBeyondChannels.size(); ++i) maps.at(layout.channel[i], y, x) = static_cast<float>(values[i]);
}

Reflectance::Reflectance(const fitting::WardParams<double>& params, const BeyondGd10& beyond) : beyond_(beyond), params_(params) {
  if (params.a_s.isZero() && !beyond.any()) return;
  lobe_.emplace(params);
  if (!(beyond.meso_deg > 0)) return;
  const fitting::AnisotropyFrame<double> frame = fitting::MakeAnisotropyFrame(params.n_s, params.alpha);
  const double tilt = DegToRad(beyond.meso_deg);
  for (const Eigen::Vector3d& towards : {frame.t, Eigen::Vector3d(-frame.t), frame.b, Eigen::Vector3d(-frame.b)}) {
    fitting::WardParams<double> facet = params;
    facet.n_s = (std::cos(tilt) * params.n_s + std::sin(tilt) * towards).normalized();
    facets_.emplace_back(facet);
  }
}

double Reflectance::EvaluateCos(const Eigen::Vector3d& l, const Eigen::Vector3d& v, const Eigen::Vector3d& weights) const {
  if (!lobe_) return DiffuseCos(l, v, weights);
  if (facets_.empty()) return FacetCos(*lobe_, l, v, weights);
  double sum = 0;
  for (const fitting::WardLobe<double>& facet : facets_) sum += FacetCos(facet, l, v, weights);
  return sum / static_cast<double>(facets_.size());
}

double Reflectance::DiffuseCos(const Eigen::Vector3d& l, const Eigen::Vector3d& v, const Eigen::Vector3d& weights) const {
  // WardLobe::Terms' conditions, in its order; its specular term times a zero a_s added nothing.
  const Eigen::Vector3d& n = params_.n_s;
  if (l.z() <= 0 || v.z() <= 0) return 0;
  const double n_dot_l = n.dot(l);
  if (n_dot_l <= 0 || n.dot(v) <= 0 || (l + v).squaredNorm() < 1e-20) return 0;
  return weights.dot(params_.a_d) * (1.0 / kPi) * n_dot_l;
}

double Reflectance::FacetCos(const fitting::WardLobe<double>& lobe, const Eigen::Vector3d& l, const Eigen::Vector3d& v,
                             const Eigen::Vector3d& weights) const {
  const fitting::WardTerms<double> terms = lobe.Terms(l, v);
  if (terms.cos_l <= 0) return 0;
  const fitting::WardParams<double>& p = lobe.params();
  double f = weights.dot(p.a_d) * terms.diffuse + weights.dot(p.a_s) * terms.specular;
  if (beyond_.coat.any()) {
    const Eigen::Vector3d h = (l + v).normalized();
    const double n_dot_v = p.n_s.dot(v);
    const double a = std::max(beyond_.coat_roughness, 1e-3);
    const double one_minus_c = 1 - std::clamp(l.dot(h), 0.0, 1.0);
    const double fresnel = p.f0 + (1 - p.f0) * std::pow(one_minus_c, 5);
    const double masking = GgxMasking(terms.cos_l, a) * GgxMasking(n_dot_v, a);
    f += weights.dot(beyond_.coat) * fresnel * GgxDistribution(p.n_s.dot(h), a) * masking / (4 * terms.cos_l * n_dot_v);
  }
  if (beyond_.fibre_masking > 0) {
    const Eigen::Vector3d& t = lobe.frame().t;
    f *= FibreMasking(l, p.n_s, t, beyond_.fibre_masking) * FibreMasking(v, p.n_s, t, beyond_.fibre_masking);
  }
  return f * terms.cos_l;
}

}  // namespace loom::sim
