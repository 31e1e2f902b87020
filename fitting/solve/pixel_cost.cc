// Analytic Jacobians of the per-pixel cost (fitting/solve/internal/pixel_cost.h).
//
// For one light sample (l, v fixed; h = normalize(l + v) and c = l·h do not depend on the
// parameters), with t' = t0 − (t0·n) n, t = t' / |t'|, b = n × t:
//   e    = (h_t² / σx² + h_b² / σy²) / h_n²,   lobe = exp(−e) / (4π σx σy c² h_n⁴)
//   spec = F · lobe,   F = F0 + (1 − F0) k,   k = (1 − c)⁵
//   L   += E · (w·a_d / π + w·a_s · spec) · (n·l)
// so with q = E · (w·a_s) · spec · (n·l):
//   ∂L/∂a_d = w · E (n·l) / π          ∂L/∂a_s = w · E spec (n·l)
//   ∂L/∂F0  = E (w·a_s) (1 − k) lobe (n·l)
//   ∂L/∂σx  = q (2 h_t² / (σx³ h_n²) − 1/σx)      (σy alike with h_b)
//   ∂L/∂α   = −q ∂e/∂α,  ∂e/∂α = 2 (h_t/σx² h·∂t/∂α + h_b/σy² h·∂b/∂α) / h_n²
//   ∂L/∂n   = E (w·a_d/π + w·a_s spec) l + q (−4 h / h_n − ∂e/∂n)
//   ∂e/∂n   = 2 (h_t/σx² ∂h_t/∂n + h_b/σy² ∂h_b/∂n) / h_n² − 2 e h / h_n
// where, for u·t with u fixed, ∂(u·t)/∂n = −(t0 (n·g) + (t0·n) g), g = (u − t (t·u)) / |t'|,
// and h_b = (h × n)·t, so ∂h_b/∂n = t × h + that with u = h × n. Since t ⟂ n, n·g = h_n / |t'|
// for u = h and 0 for u = h × n, whose t·u = h_b:
//   ∂h_t/∂n = −(t0 h_n + (t0·n)(h − t h_t)) / |t'|
//   ∂h_b/∂n = t × h − (t0·n)(h × n − t h_b) / |t'|
// n is differentiated in the ambient R³: the fitter's SphereManifold projects it.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "fitting/solve/internal/pixel_cost.h"

namespace loom::fitting::internal {
namespace {

// The lobe's parameter-dependent quantities, prepared once per evaluation.
struct PreparedLobe {
  Eigen::Vector3d n;
  Eigen::Vector3d a_d, a_s;
  double sigma_x, sigma_y, inv_sigma_x2, inv_sigma_y2, normalisation, f0;
  bool sigma_x_floored, sigma_y_floored;
  Eigen::Vector3d t0, t, b, dt_dalpha, db_dalpha;
  double t0_dot_n, inv_t_prime_norm;

  explicit PreparedLobe(double const* const* blocks)
      : n(blocks[0][0], blocks[0][1], blocks[0][2]),
        a_d(blocks[1][0], blocks[1][1], blocks[1][2]),
        a_s(blocks[2][0], blocks[2][1], blocks[2][2]),
        f0(blocks[5][0]) {
    sigma_x_floored = blocks[3][0] < kSigmaFloor;
    sigma_y_floored = blocks[3][1] < kSigmaFloor;
    sigma_x = sigma_x_floored ? kSigmaFloor : blocks[3][0];
    sigma_y = sigma_y_floored ? kSigmaFloor : blocks[3][1];
    inv_sigma_x2 = 1 / (sigma_x * sigma_x);
    inv_sigma_y2 = 1 / (sigma_y * sigma_y);
    normalisation = 1 / (4 * kPi * sigma_x * sigma_y);
    const double alpha = blocks[4][0];
    t0 = Eigen::Vector3d(std::cos(alpha), std::sin(alpha), 0);
    t0_dot_n = t0.dot(n);
    const Eigen::Vector3d t_prime = t0 - t0_dot_n * n;
    inv_t_prime_norm = 1 / t_prime.norm();
    t = t_prime * inv_t_prime_norm;
    b = n.cross(t);
    const Eigen::Vector3d dt0(-std::sin(alpha), std::cos(alpha), 0);
    const Eigen::Vector3d dt_prime = dt0 - dt0.dot(n) * n;
    dt_dalpha = (dt_prime - t * t.dot(dt_prime)) * inv_t_prime_norm;
    db_dalpha = n.cross(dt_dalpha);
  }
};

// The gradient of one observation's radiance, in block order (13 entries).
struct Gradient {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_d = Eigen::Vector3d::Zero();
  Eigen::Vector3d a_s = Eigen::Vector3d::Zero();
  double sigma_x = 0, sigma_y = 0, alpha = 0, f0 = 0;
};

// What of one light sample does not depend on the parameters (l and v are fixed): computed
// once per fit instead of once per evaluation.
struct FixedLight {
  Eigen::Vector3d l;
  Eigen::Vector3d h;  // normalize(l + v)
  double irradiance;
  double inv_c2;   // 1 / (l·h)²
  double schlick;  // (1 − l·h)⁵
};

struct FixedObservation {
  Eigen::Vector3d v;
  Eigen::Vector3d rgb_weights;
  double radiance;
  int first_light, end_light;  // into the cost's light list
};

// Beyond this exponent the lobe's exp(−e) (< 1e-26) times its largest normalisation (σ at its
// floor) is no measurable fraction of the diffuse term, and exp() would underflow through
// libm's slow path (8 % of a fit's time on a reconstructed stack, measured with perf).
constexpr double kNegligibleLobeExponent = 60;

// The radiance the model predicts for observation `o` with lights [first, end); with
// `gradient`, also its derivatives.
double Radiance(const PreparedLobe& lobe, const FixedObservation& o, const std::vector<FixedLight>& lights, Gradient* gradient) {
  const Eigen::Vector3d& n = lobe.n;
  if (n.dot(o.v) <= 0) return 0;
  const double diffuse_albedo = o.rgb_weights.dot(lobe.a_d);
  const double specular_albedo = o.rgb_weights.dot(lobe.a_s);
  double radiance = 0;
  double diffuse_sum = 0, specular_sum = 0, fresnel_sum = 0;  // Σ E (n·l)/π, Σ E spec (n·l), Σ E (1−k) lobe (n·l)
  for (int j = o.first_light; j < o.end_light; ++j) {
    const FixedLight& light = lights[j];
    const Eigen::Vector3d& l = light.l;
    const Eigen::Vector3d& h = light.h;
    const double n_dot_l = n.dot(l);
    if (n_dot_l <= 0) continue;
    const double h_t = h.dot(lobe.t), h_b = h.dot(lobe.b), h_n = h.dot(n);
    const double h_n2 = h_n * h_n;
    const double exponent = (h_t * h_t * lobe.inv_sigma_x2 + h_b * h_b * lobe.inv_sigma_y2) / h_n2;
    const double e = light.irradiance;
    if (exponent > kNegligibleLobeExponent) {  // far from the highlight: the diffuse term alone
      const double shading = e * diffuse_albedo / kPi;
      radiance += shading * n_dot_l;
      if (!gradient) continue;
      diffuse_sum += e * n_dot_l / kPi;
      gradient->n += shading * l;
      continue;
    }
    const double ward = std::exp(-exponent) * lobe.normalisation * light.inv_c2 / (h_n2 * h_n2);
    const double fresnel = lobe.f0 + (1 - lobe.f0) * light.schlick;
    const double specular = fresnel * ward;
    const double shading = e * (diffuse_albedo / kPi + specular_albedo * specular);
    radiance += shading * n_dot_l;
    if (!gradient) continue;
    diffuse_sum += e * n_dot_l / kPi;
    specular_sum += e * specular * n_dot_l;
    fresnel_sum += e * (1 - light.schlick) * ward * n_dot_l;
    const double q = e * specular_albedo * specular * n_dot_l;
    const double tx = h_t * lobe.inv_sigma_x2, by = h_b * lobe.inv_sigma_y2;
    if (!lobe.sigma_x_floored) gradient->sigma_x += q * (2 * h_t * tx / (lobe.sigma_x * h_n2) - 1 / lobe.sigma_x);
    if (!lobe.sigma_y_floored) gradient->sigma_y += q * (2 * h_b * by / (lobe.sigma_y * h_n2) - 1 / lobe.sigma_y);
    gradient->alpha -= q * 2 * (tx * h.dot(lobe.dt_dalpha) + by * h.dot(lobe.db_dalpha)) / h_n2;
    const Eigen::Vector3d dh_t = -(lobe.t0 * h_n + lobe.t0_dot_n * (h - lobe.t * h_t)) * lobe.inv_t_prime_norm;
    const Eigen::Vector3d dh_b = lobe.t.cross(h) - lobe.t0_dot_n * (h.cross(n) - lobe.t * h_b) * lobe.inv_t_prime_norm;
    const Eigen::Vector3d de_dn = 2 * (tx * dh_t + by * dh_b) / h_n2 - (2 * exponent / h_n) * h;
    gradient->n += shading * l + q * (-4 / h_n * h - de_dn);
  }
  if (gradient) {
    gradient->a_d = o.rgb_weights * diffuse_sum;
    gradient->a_s = o.rgb_weights * specular_sum;
    gradient->f0 = specular_albedo * fresnel_sum;
  }
  return radiance;
}

class AnalyticPixelCost : public ceres::CostFunction {
 public:
  AnalyticPixelCost(const std::vector<PixelObservation>& observations, double inverse_scale) : inverse_scale_(inverse_scale) {
    for (int size : kParameterBlockSizes) mutable_parameter_block_sizes()->push_back(size);
    set_num_residuals(static_cast<int>(observations.size()));
    for (const PixelObservation& o : observations) Add(o);
  }

  bool Evaluate(double const* const* blocks, double* residuals, double** jacobians) const override {
    const PreparedLobe lobe(blocks);
    Gradient gradient;
    for (size_t k = 0; k < observations_.size(); ++k) {
      const FixedObservation& o = observations_[k];
      gradient = Gradient{};
      const double radiance = Radiance(lobe, o, lights_, jacobians ? &gradient : nullptr);
      residuals[k] = (radiance - o.radiance) * inverse_scale_;
      if (jacobians) Store(gradient, k, jacobians);
    }
    return true;
  }

 private:
  // The model's zero conditions that do not depend on the parameters (l·z ≤ 0, v·z ≤ 0,
  // l + v ≈ 0) drop a light, or all of an observation's, here once.
  void Add(const PixelObservation& o) {
    FixedObservation fixed{o.v_local, o.rgb_weights, o.radiance, static_cast<int>(lights_.size()), 0};
    for (const LightSample& light : o.lights) {
      const Eigen::Vector3d sum = light.l_local + o.v_local;
      if (o.v_local.z() <= 0 || light.l_local.z() <= 0 || sum.squaredNorm() < 1e-20) continue;
      const Eigen::Vector3d h = sum.normalized();
      const double c = std::clamp(light.l_local.dot(h), 0.0, 1.0);
      const double one_minus_c = 1 - c;
      const double schlick = one_minus_c * one_minus_c * one_minus_c * one_minus_c * one_minus_c;
      lights_.push_back({light.l_local, h, light.irradiance, 1 / (c * c), schlick});
    }
    fixed.end_light = static_cast<int>(lights_.size());
    observations_.push_back(fixed);
  }

  // Ceres' Jacobians: one row-major (residuals × block size) array per block; null = not wanted.
  void Store(const Gradient& g, size_t row, double** jacobians) const {
    const double s = inverse_scale_;
    const auto put = [&](int block, int size, const double* values) {
      if (!jacobians[block]) return;
      for (int j = 0; j < size; ++j) jacobians[block][row * size + j] = values[j] * s;
    };
    put(0, 3, g.n.data());
    put(1, 3, g.a_d.data());
    put(2, 3, g.a_s.data());
    const double sigma[2] = {g.sigma_x, g.sigma_y};
    put(3, 2, sigma);
    put(4, 1, &g.alpha);
    put(5, 1, &g.f0);
  }

  std::vector<FixedObservation> observations_;
  std::vector<FixedLight> lights_;
  double inverse_scale_;
};

// ∂r̃/∂r = a / |r̃| beyond the threshold: the gradient of ½ r̃² is a·sign(r)·∂r, as for ρ.
class RobustPixelCost : public ceres::CostFunction {
 public:
  RobustPixelCost(ceres::CostFunction* inner, double huber_scale) : inner_(inner), a_(huber_scale) {
    *mutable_parameter_block_sizes() = inner->parameter_block_sizes();
    set_num_residuals(inner->num_residuals());
  }

  bool Evaluate(double const* const* blocks, double* residuals, double** jacobians) const override {
    if (!inner_->Evaluate(blocks, residuals, jacobians)) return false;
    const std::vector<int32_t>& sizes = parameter_block_sizes();
    for (int k = 0; k < num_residuals(); ++k) {
      const double r = residuals[k];
      if (std::abs(r) <= a_) continue;
      const double robust = std::copysign(std::sqrt(2 * a_ * std::abs(r) - a_ * a_), r);
      residuals[k] = robust;
      if (!jacobians) continue;
      const double factor = a_ / std::abs(robust);
      for (size_t b = 0; b < sizes.size(); ++b) {
        if (!jacobians[b]) continue;
        for (int j = 0; j < sizes[b]; ++j) jacobians[b][k * sizes[b] + j] *= factor;
      }
    }
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
  double a_;
};

// a_s = b / F0 into `inner`; by the chain rule ∂r/∂b = ∂r/∂a_s / F0 and, b held,
// ∂r/∂F0 = ∂r/∂F0|a_s − Σ ∂r/∂a_s · a_s / F0.
class SpecularAtNormalIncidenceCost : public ceres::CostFunction {
 public:
  explicit SpecularAtNormalIncidenceCost(ceres::CostFunction* inner) : inner_(inner) {
    *mutable_parameter_block_sizes() = inner->parameter_block_sizes();
    set_num_residuals(inner->num_residuals());
  }

  bool Evaluate(double const* const* blocks, double* residuals, double** jacobians) const override {
    const double f0 = blocks[5][0];
    const double a_s[3] = {blocks[2][0] / f0, blocks[2][1] / f0, blocks[2][2] / f0};
    const double* inner_blocks[6] = {blocks[0], blocks[1], a_s, blocks[3], blocks[4], blocks[5]};
    if (!jacobians) return inner_->Evaluate(inner_blocks, residuals, nullptr);
    const int rows = num_residuals();
    // F0's column needs ∂r/∂a_s even where the caller asks no Jacobian of b.
    std::vector<double> own_a_s_jacobian;
    double* inner_jacobians[6] = {jacobians[0], jacobians[1], jacobians[2], jacobians[3], jacobians[4], jacobians[5]};
    if (!inner_jacobians[2] && jacobians[5]) {
      own_a_s_jacobian.resize(static_cast<size_t>(rows) * 3);
      inner_jacobians[2] = own_a_s_jacobian.data();
    }
    if (!inner_->Evaluate(inner_blocks, residuals, inner_jacobians)) return false;
    for (int k = 0; k < rows; ++k) {
      double* by_a_s = inner_jacobians[2] + 3 * k;
      if (jacobians[5]) jacobians[5][k] -= (by_a_s[0] * a_s[0] + by_a_s[1] * a_s[1] + by_a_s[2] * a_s[2]) / f0;
      if (jacobians[2]) {
        for (int c = 0; c < 3; ++c) by_a_s[c] /= f0;
      }
    }
    return true;
  }

 private:
  std::unique_ptr<ceres::CostFunction> inner_;
};

}  // namespace

ceres::CostFunction* MakeRobustPixelCost(ceres::CostFunction* inner, double huber_scale) {
  return new RobustPixelCost(inner, huber_scale);
}

ceres::CostFunction* MakeSpecularAtNormalIncidenceCost(ceres::CostFunction* inner) {
  return new SpecularAtNormalIncidenceCost(inner);
}

ceres::CostFunction* MakeAnalyticPixelCost(const std::vector<PixelObservation>& observations, double inverse_scale) {
  return new AnalyticPixelCost(observations, inverse_scale);
}

}  // namespace loom::fitting::internal
