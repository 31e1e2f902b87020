#include "fitting/model/strip_quadrature.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/check.h"
#include "core/geometry.h"

namespace loom::fitting {

Status StripQuadratureOptions::Check() const {
  std::vector<std::string> problems;
  if (side_nodes < 1) problems.push_back("side_nodes must be ≥ 1");
  if (lobe_nodes < 1) problems.push_back("lobe_nodes must be ≥ 1");
  if (!(lobe_fraction > 0 && lobe_fraction < 1)) problems.push_back("lobe_fraction must be in (0, 1)");
  if (!(moved_fraction >= lobe_fraction && moved_fraction < 1))
    problems.push_back("moved_fraction must be in [lobe_fraction, 1)");
  if (Nodes() >= 128) problems.push_back("side_nodes and lobe_nodes make 2 side + lobe ≥ 128 nodes");
  if (!(margin >= 0 && margin <= 1)) problems.push_back("margin must be in [0, 1]");
  return ProblemsStatus("strip quadrature options", problems);
}

StripQuadratureOptions StripQuadratureWithNodes(int nodes) {
  StripQuadratureOptions options;
  options.side_nodes = nodes / 5;
  options.lobe_nodes = nodes - 2 * options.side_nodes;
  return options;
}

std::optional<StripSegment> StripOfEmitters(std::span<const PointEmitter> emitters) {
  const size_t n = emitters.size();
  if (n < 2) return std::nullopt;
  const PointEmitter& first = emitters.front();
  if (std::any_of(emitters.begin(), emitters.end(), [](const PointEmitter& e) { return e.at_infinity; })) return std::nullopt;
  const Eigen::Vector3d step = (emitters.back().position_mm - first.position_mm) / static_cast<double>(n - 1);
  const double spacing = step.norm();
  if (!(spacing > 0)) return std::nullopt;
  for (size_t k = 0; k < n; ++k) {
    const PointEmitter& e = emitters[k];
    const bool in_row = (e.position_mm - (first.position_mm + static_cast<double>(k) * step)).norm() <= 1e-6 * spacing * n;
    if (!in_row || e.axis != first.axis || e.intensity != first.intensity || e.falloff_exponent != first.falloff_exponent) {
      return std::nullopt;
    }
  }
  // Midpoints of n equal segments: the strip reaches half a spacing beyond the first and last.
  return StripSegment{first.position_mm - step / 2, emitters.back().position_mm + step / 2, first.axis, first.intensity / spacing,
                      first.falloff_exponent};
}

std::vector<std::pair<double, double>> GaussLegendreRule(int n) {
  std::vector<std::pair<double, double>> rule;
  for (int i = 0; i < n; ++i) {
    // Newton's method on P_n from the Chebyshev-like guess, P_n and P_{n−1} by the recurrence.
    double x = std::cos(kPi * (i + 0.75) / (n + 0.5)), derivative = 1;
    for (int step = 0; step < 100; ++step) {
      double p_previous = 1, p = x;
      for (int k = 2; k <= n; ++k) {
        const double next = ((2 * k - 1) * x * p - (k - 1) * p_previous) / k;
        p_previous = p;
        p = next;
      }
      derivative = n * (x * p - p_previous) / (x * x - 1);
      const double dx = p / derivative;
      x -= dx;
      if (std::abs(dx) < 1e-15) break;
    }
    rule.push_back({x, 2 / ((1 - x * x) * derivative * derivative)});
  }
  return rule;
}

namespace {

// GaussLegendreRule(n) for n < kCachedRules, computed once: the nodes are placed per pixel and
// observation, and Newton's iterations cost more than the rest of the placement.
constexpr int kCachedRules = 128;
const std::vector<std::pair<double, double>>& CachedRule(int n) {
  static const std::vector<std::vector<std::pair<double, double>>> rules = [] {
    std::vector<std::vector<std::pair<double, double>>> all(kCachedRules);
    for (int k = 1; k < kCachedRules; ++k) all[k] = GaussLegendreRule(k);
    return all;
  }();
  LOOM_CHECK(n >= 1 && n < kCachedRules) << "a Gauss–Legendre rule of " << n << " nodes";
  return rules[n];
}

}  // namespace

std::pair<double, double> LobeSpan(std::span<const Eigen::Vector3d> l_local, const Eigen::Vector3d& v_local,
                                   const WardParams<double>& params, double fraction) {
  const Eigen::Vector3d& n = params.n_s;
  const int count = static_cast<int>(l_local.size());
  if (n.dot(v_local) <= 0 || count == 0) return {0.0, 1.0};
  const AnisotropyFrame<double> frame = MakeAnisotropyFrame(n, params.alpha);
  const double inv_sx2 = 1 / std::pow(std::max(params.sigma_x, kSigmaFloor), 2);
  const double inv_sy2 = 1 / std::pow(std::max(params.sigma_y, kSigmaFloor), 2);
  // The lobe's exponent at each point (infinite below a horizon), and the lowest.
  thread_local std::vector<double> exponent;
  exponent.assign(count, std::numeric_limits<double>::infinity());
  double lowest = std::numeric_limits<double>::infinity();
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d& l = l_local[i];
    if (l.z() <= 0 || n.dot(l) <= 0) continue;
    const Eigen::Vector3d h = l + v_local;  // unnormalised: the exponent is a ratio in h
    const double h_t = h.dot(frame.t), h_b = h.dot(frame.b), h_n = h.dot(n);
    exponent[i] = (h_t * h_t * inv_sx2 + h_b * h_b * inv_sy2) / (h_n * h_n);
    lowest = std::min(lowest, exponent[i]);
  }
  if (!std::isfinite(lowest)) return {0.0, 1.0};
  const double highest = lowest + std::log(1 / fraction);
  int first = count, last = -1;
  for (int i = 0; i < count; ++i) {
    if (exponent[i] <= highest) first = std::min(first, i), last = std::max(last, i);
  }
  return {(first + 0.5) / count, (last + 0.5) / count};
}

namespace {

// Appends `nodes` Gauss–Legendre emitters over [a, b] (fractions of the strip).
void AppendPart(const StripSegment& strip, double a, double b, int nodes, std::vector<PointEmitter>& out) {
  const double length_mm = strip.LengthMm();
  for (const auto& [x, weight] : CachedRule(nodes)) {
    const double u = (a + b) / 2 + (b - a) / 2 * x;
    out.push_back({strip.At(u), strip.axis, strip.intensity_per_mm * length_mm * (b - a) / 2 * weight, strip.falloff_exponent});
  }
}

}  // namespace

std::vector<PointEmitter> StripNodes(const StripSegment& strip, std::pair<double, double> lit,
                                     std::pair<double, double> lobe_span, const StripQuadratureOptions& options) {
  double lo = std::max(lit.first, lobe_span.first - options.margin);
  double hi = std::min(lit.second, lobe_span.second + options.margin);
  if (lo >= hi) lo = lit.first, hi = lit.second;  // the lobe is where the strip does not light the pixel
  const bool before = lo > lit.first, after = hi < lit.second;
  std::vector<PointEmitter> nodes;
  nodes.reserve(options.Nodes());
  if (before) AppendPart(strip, lit.first, lo, options.side_nodes, nodes);
  AppendPart(strip, lo, hi, options.lobe_nodes + options.side_nodes * (!before + !after), nodes);
  if (after) AppendPart(strip, hi, lit.second, options.side_nodes, nodes);
  return nodes;
}

std::vector<LightSample> MergeLightSamples(const std::vector<LightSample>& lights, int count) {
  const int n = static_cast<int>(lights.size());
  if (n <= count || count < 1) return lights;
  std::vector<LightSample> merged;
  for (int g = 0; g < count; ++g) {
    Eigen::Vector3d direction = Eigen::Vector3d::Zero();
    double irradiance = 0;
    for (int j = g * n / count; j < (g + 1) * n / count; ++j) {
      direction += lights[j].irradiance * lights[j].l_local;
      irradiance += lights[j].irradiance;
    }
    if (irradiance > 0) merged.push_back({direction.normalized(), irradiance});
  }
  return merged;
}

}  // namespace loom::fitting
