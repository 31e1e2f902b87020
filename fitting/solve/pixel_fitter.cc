#include "fitting/solve/pixel_fitter.h"

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/sphere_manifold.h>

#include "fitting/solve/internal/pixel_cost.h"

#include <algorithm>
#include <cmath>
#include <memory>

namespace loom::fitting {
namespace {

struct Blocks {
  double n_s[3];
  double a_d[3];
  double a_s[3];
  double sigma[2];
  double alpha[1];
  double f0[1];

  explicit Blocks(const WardParams<double>& p)
      : n_s{p.n_s.x(), p.n_s.y(), p.n_s.z()},
        a_d{p.a_d.x(), p.a_d.y(), p.a_d.z()},
        a_s{p.a_s.x(), p.a_s.y(), p.a_s.z()},
        sigma{p.sigma_x, p.sigma_y},
        alpha{p.alpha},
        f0{p.f0} {}

  WardParams<double> Params() const {
    WardParams<double> p;
    p.n_s = Eigen::Vector3d(n_s[0], n_s[1], n_s[2]).normalized();
    p.a_d = Eigen::Vector3d(a_d[0], a_d[1], a_d[2]);
    p.a_s = Eigen::Vector3d(a_s[0], a_s[1], a_s[2]);
    p.sigma_x = sigma[0];
    p.sigma_y = sigma[1];
    // α and α + π are the same lobe: wrap into (−π/2, π/2].
    p.alpha = alpha[0] - kPi * std::ceil((alpha[0] - kPi / 2) / kPi);
    p.f0 = f0[0];
    return p;
  }
};

struct Start {
  PixelFitResult result;
  bool ok = false;
};

// How a pixel's a_s block is read: a_s itself, or b = a_s·F0 (MakeSpecularAtNormalIncidenceCost).
enum class SpecularBlock { kAlbedo, kAtNormalIncidence };

// Adds one pixel's robust cost over `blocks` to `problem`, with the parameters' bounds; its F0
// is `f0` (the pixel's own block, or one that pixels share), bounded to [0, 1] unless constant
// (to [kMinSharedF0, 1] with b in a_s's block, which divides by it).
void AddPixel(ceres::Problem& problem, const std::vector<PixelObservation>& usable, double inverse_scale, Blocks& blocks,
              double* f0, const PixelFitOptions& options, SpecularBlock specular = SpecularBlock::kAlbedo) {
  ceres::CostFunction* cost = options.automatic_derivatives ? internal::MakeAutodiffPixelCost(usable, inverse_scale)
                                                            : internal::MakeAnalyticPixelCost(usable, inverse_scale);
  if (specular == SpecularBlock::kAtNormalIncidence) cost = internal::MakeSpecularAtNormalIncidenceCost(cost);
  cost = internal::MakeRobustPixelCost(cost, options.huber_scale);
  problem.AddResidualBlock(cost, nullptr, blocks.n_s, blocks.a_d, blocks.a_s, blocks.sigma, blocks.alpha, f0);
  problem.SetManifold(blocks.n_s, new ceres::SphereManifold<3>());
  for (int i = 0; i < 3; ++i) {
    problem.SetParameterLowerBound(blocks.a_d, i, 0);
    problem.SetParameterLowerBound(blocks.a_s, i, 0);
    problem.SetParameterUpperBound(blocks.a_d, i, kMaxAlbedo);
    problem.SetParameterUpperBound(blocks.a_s, i, kMaxAlbedo);
  }
  for (int i = 0; i < 2; ++i) {
    problem.SetParameterLowerBound(blocks.sigma, i, options.min_sigma);
    problem.SetParameterUpperBound(blocks.sigma, i, kMaxSigma);
  }
  if (!problem.IsParameterBlockConstant(f0)) {
    problem.SetParameterLowerBound(f0, 0, specular == SpecularBlock::kAtNormalIncidence ? kMinSharedF0 : 0);
    problem.SetParameterUpperBound(f0, 0, 1);
  }
}

Start FitFrom(const std::vector<PixelObservation>& usable, double inverse_scale, const WardParams<double>& initial,
              const PixelFitOptions& options) {
  Blocks blocks(initial);
  for (double& sigma : blocks.sigma) sigma = std::clamp(sigma, options.min_sigma, kMaxSigma);
  ceres::Problem problem;
  if (options.fixed_f0) blocks.f0[0] = *options.fixed_f0;
  problem.AddParameterBlock(blocks.f0, 1);
  if (options.fixed_f0) problem.SetParameterBlockConstant(blocks.f0);
  AddPixel(problem, usable, inverse_scale, blocks, blocks.f0, options);
  if (options.hold_normal) problem.SetParameterBlockConstant(blocks.n_s);
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = options.max_iterations;
  solver.num_threads = 1;  // parallelism is over pixels
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  Start start;
  start.ok = summary.IsSolutionUsable();
  start.result.params = blocks.Params();
  start.result.cost = summary.final_cost;
  start.result.observations_used = static_cast<int>(usable.size());
  start.result.iterations = static_cast<int>(summary.iterations.size());
  start.result.converged = summary.termination_type == ceres::CONVERGENCE;
  return start;
}

// A pixel's observations that carry a radiance and a light, and the inverse of their mean
// radiance (residuals are relative to it); fewer than 13 is an error.
struct UsableObservations {
  std::vector<PixelObservation> observations;
  double inverse_scale = 1;
};
Result<UsableObservations> Usable(const std::vector<PixelObservation>& observations) {
  UsableObservations usable;
  double sum = 0;
  for (const PixelObservation& o : observations) {
    if (!std::isfinite(o.radiance) || o.lights.empty()) continue;
    usable.observations.push_back(o);
    sum += std::abs(o.radiance);
  }
  const size_t count = usable.observations.size();
  if (count < kNumWardParams) {
    return FailedPreconditionError(
        "pixel fit", std::to_string(count) + " usable observations, need at least " + std::to_string(kNumWardParams));
  }
  const double mean = sum / count;
  if (mean > 0) usable.inverse_scale = 1 / mean;
  return usable;
}

std::vector<WardParams<double>> Starts(const WardParams<double>& initial, bool multi_start) {
  std::vector<WardParams<double>> starts = {initial};
  if (!multi_start) return starts;
  for (double turn : {kPi / 4, kPi / 2, 3 * kPi / 4}) {
    WardParams<double> start = initial;
    start.alpha += turn;
    starts.push_back(start);
  }
  return starts;
}

}  // namespace

bool AllFinite(const WardParams<double>& p) {
  return p.n_s.allFinite() && p.a_d.allFinite() && p.a_s.allFinite() && std::isfinite(p.sigma_x) && std::isfinite(p.sigma_y) &&
         std::isfinite(p.alpha) && std::isfinite(p.f0);
}

Status PixelFitOptions::Check() const {
  std::vector<std::string> problems;
  if (max_iterations < 1) problems.push_back("max_iterations must be ≥ 1");
  if (!(huber_scale > 0)) problems.push_back("huber_scale must be > 0");
  if (fixed_f0 && !(*fixed_f0 >= 0 && *fixed_f0 <= 1)) problems.push_back("fixed_f0 must be in [0, 1]");
  if (!(min_sigma >= kMinSigma && min_sigma < kMaxSigma)) problems.push_back("min_sigma must be in [kMinSigma, kMaxSigma)");
  return ProblemsStatus("PixelFitOptions", problems);
}

WardParams<double> GenericInitialParams(const std::vector<PixelObservation>& observations) {
  // a_d as if every observation were Lambertian under its lights: L = a·Σ E cos / π.
  double measured = 0;
  double lambert = 0;
  for (const PixelObservation& o : observations) {
    if (std::isnan(o.radiance)) continue;
    double shading = 0;
    for (const LightSample& light : o.lights) shading += light.irradiance * std::max(0.0, light.l_local.z()) / kPi;
    measured += o.radiance;
    lambert += shading * o.rgb_weights.sum();
  }
  WardParams<double> p;
  p.a_d = Eigen::Vector3d::Constant(lambert > 0 ? std::clamp(0.5 * measured / lambert, 0.01, 1.0) : 0.3);
  p.a_s = Eigen::Vector3d::Constant(0.1);
  p.sigma_x = 0.2;
  p.sigma_y = 0.2;
  return p;
}

Result<PixelFitResult> FitPixel(const std::vector<PixelObservation>& observations, const WardParams<double>& initial,
                                const PixelFitOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  if (!AllFinite(initial)) return InvalidArgumentError("pixel fit", "the start has a non-finite parameter (NaN or Inf)");
  LOOM_ASSIGN_OR_RETURN(const UsableObservations usable_observations, Usable(observations));
  const auto& [usable, inverse_scale] = usable_observations;
  Start best;
  for (const WardParams<double>& start : Starts(initial, options.multi_start)) {
    Start fitted = FitFrom(usable, inverse_scale, start, options);
    const int iterations = best.result.iterations + fitted.result.iterations;
    if (fitted.ok && (!best.ok || fitted.result.cost < best.result.cost)) best = std::move(fitted);
    best.result.iterations = iterations;
  }
  if (!best.ok) return InternalError("pixel fit", "Ceres found no usable solution from any start");
  return best.result;
}

Result<SharedF0Fit> FitPixelsSharingF0(const std::vector<std::vector<PixelObservation>>& pixels,
                                       const std::vector<WardParams<double>>& starts, double f0_start,
                                       const PixelFitOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  if (starts.size() != pixels.size()) {
    return InvalidArgumentError("shared-F0 fit",
                                std::to_string(starts.size()) + " starts for " + std::to_string(pixels.size()) + " pixels");
  }
  SharedF0Fit fit;
  fit.f0 = std::clamp(f0_start, kMinSharedF0, 1.0);
  fit.pixels.resize(pixels.size());
  std::vector<std::optional<UsableObservations>> usable(pixels.size());
  std::vector<std::unique_ptr<Blocks>> blocks(pixels.size());
  ceres::Problem problem;
  problem.AddParameterBlock(&fit.f0, 1);
  for (size_t k = 0; k < pixels.size(); ++k) {
    Result<UsableObservations> u = Usable(pixels[k]);
    // Too few observations, or a start Ceres cannot move from: left out, as FitStack keeps such a
    // pixel's start.
    if (!u.ok() || !AllFinite(starts[k])) continue;
    usable[k] = std::move(*u);
    WardParams<double> start = starts[k];
    start.a_s *= start.f0;  // b = a_s·F0, what the start's observations fixed
    blocks[k] = std::make_unique<Blocks>(start);
    for (double& sigma : blocks[k]->sigma) sigma = std::clamp(sigma, options.min_sigma, kMaxSigma);
    AddPixel(problem, usable[k]->observations, usable[k]->inverse_scale, *blocks[k], &fit.f0, options,
             SpecularBlock::kAtNormalIncidence);
  }
  if (problem.NumResidualBlocks() == 0) {
    return FailedPreconditionError("shared-F0 fit", "no pixel has enough usable observations");
  }
  ceres::Solver::Options solver;
  // The normal equations are block diagonal (each pixel's own parameters) but for F0's row and
  // column: sparse. (The Schur solvers would eliminate the pixels' blocks, but a pixel's five
  // blocks share its residual, so they are no independent set.)
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = options.max_iterations;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (!summary.IsSolutionUsable()) return InternalError("shared-F0 fit", summary.message);
  fit.cost = summary.final_cost;
  fit.iterations = static_cast<int>(summary.iterations.size());
  for (size_t k = 0; k < pixels.size(); ++k) {
    if (!blocks[k]) continue;
    WardParams<double> params = blocks[k]->Params();
    params.a_s /= fit.f0;
    params.f0 = fit.f0;
    fit.pixels[k] = PixelFitResult{params, 0, static_cast<int>(usable[k]->observations.size()), fit.iterations,
                                   summary.termination_type == ceres::CONVERGENCE};
  }
  return fit;
}

}  // namespace loom::fitting
