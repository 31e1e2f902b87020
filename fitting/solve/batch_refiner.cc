#include "fitting/solve/batch_refiner.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

#include "core/check.h"
#include "core/parallel.h"
#include "fitting/solve/internal/grid_candidates.h"
#include "fitting/solve/internal/refine_kernel.h"
#include "fitting/solve/internal/refine_lanes.h"

namespace loom::fitting {
namespace {

using internal::kAmbientParams;
using internal::kLanes;
using internal::kTangentParams;
using Params = std::array<double, kAmbientParams>;
using Vector12 = Eigen::Matrix<double, kTangentParams, 1>;
using Matrix12 = Eigen::Matrix<double, kTangentParams, kTangentParams>;

// Ceres' Levenberg–Marquardt defaults (ceres::Solver::Options), so that both stop alike.
constexpr double kInitialRadius = 1e4;
constexpr double kMaxRadius = 1e16;
constexpr double kMinRadius = 1e-32;
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kMinDiagonal = 1e-6;
constexpr double kMaxDiagonal = 1e32;
// Two departures from Ceres' trust-region rule, each measured (docs/benchmarks.md).
// After a rejected step the next is at most the length where the parabola through the cost at
// both ends and the slope at the start has its minimum, within [kRetreatMin, kRetreatMax] of the
// rejected one: halving the radius from far above where the damping acts gave nearly the same
// step again, and rejected runs of 5. After a step the quadratic model predicted within
// kGoodModel, the radius grows kExtraGrowth times more.
constexpr double kRetreatMin = 0.1;
constexpr double kRetreatMax = 0.5;
constexpr double kGoodModel = 0.1;
constexpr double kExtraGrowth = 3;
// Light samples per observation from which a finished pixel is evaluated for its uncertainty in
// its own lane rather than in a batch of finished pixels (Batch::Park).
constexpr int kInPlaceSlotsPerObservation = 2;

// Tangent index → ambient index: the normal's 2 tangent coordinates stand for n_s's 3.
constexpr int Ambient(int i) { return i + 1; }
constexpr int kF0 = 11;
constexpr int kAlpha = 10;

struct Bounds {
  double lower, upper;
};
// Bounds of tangent parameter i (none for the normal and α); σ from `min_sigma`.
std::optional<Bounds> BoundsOf(int i, double min_sigma) {
  if (i >= 2 && i <= 7) return Bounds{0, kMaxAlbedo};
  if (i == 8 || i == 9) return Bounds{min_sigma, kMaxSigma};
  if (i == kF0) return Bounds{0, 1};
  return std::nullopt;
}

double WrapAngle(double alpha) { return alpha - kPi * std::ceil((alpha - kPi / 2) / kPi); }

Params Pack(const WardParams<double>& p) {
  return {p.n_s.x(), p.n_s.y(), p.n_s.z(), p.a_d.x(), p.a_d.y(), p.a_d.z(), p.a_s.x(),
          p.a_s.y(), p.a_s.z(), p.sigma_x, p.sigma_y, p.alpha,   p.f0};
}

WardParams<double> Unpack(const Params& x) {
  WardParams<double> p;
  p.n_s = Eigen::Vector3d(x[0], x[1], x[2]).normalized();
  p.a_d = Eigen::Vector3d(x[3], x[4], x[5]);
  p.a_s = Eigen::Vector3d(x[6], x[7], x[8]);
  p.sigma_x = x[9];
  p.sigma_y = x[10];
  p.alpha = WrapAngle(x[11]);
  p.f0 = x[12];
  return p;
}

struct TangentBasis {
  Eigen::Vector3d u = Eigen::Vector3d::UnitX(), v = Eigen::Vector3d::UnitY();
};

TangentBasis BasisOf(const Params& x) {
  const Eigen::Vector3d n = Eigen::Vector3d(x[0], x[1], x[2]).normalized();
  const Eigen::Vector3d a = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d u = (a - a.dot(n) * n).normalized();
  return {u, n.cross(u)};
}

// The prior's precision per tangent parameter (0: none) and its residual d = x − start.
struct Prior {
  Vector12 precision = Vector12::Zero();

  explicit Prior(const RefinePrior& prior) {
    if (prior.weight <= 0) return;
    const double deg = kPi / 180;
    const auto set = [&](int first, int last, double sigma) {
      for (int i = first; i <= last; ++i) precision[i] = prior.weight / (sigma * sigma);
    };
    set(0, 1, prior.normal_deg * deg);
    set(2, 4, prior.diffuse_albedo);
    set(5, 7, prior.specular_albedo);
    set(8, 9, prior.sigma);
    set(kAlpha, kAlpha, prior.alpha_deg * deg);
  }
  bool active() const { return precision.any(); }

  Vector12 Difference(const Params& x, const TangentBasis& basis, const Params& start) const {
    Vector12 d = Vector12::Zero();
    const Eigen::Vector3d dn =
        Eigen::Vector3d(x[0], x[1], x[2]).normalized() - Eigen::Vector3d(start[0], start[1], start[2]).normalized();
    d[0] = basis.u.dot(dn);
    d[1] = basis.v.dot(dn);
    for (int i = 2; i < kAlpha; ++i) d[i] = x[Ambient(i)] - start[Ambient(i)];
    d[kAlpha] = WrapAngle(x[Ambient(kAlpha)] - start[Ambient(kAlpha)]);
    return d;
  }
};

// One pixel's LM state in a lane.
struct Lane {
  int pixel = -1;
  Params start{}, x{}, trial{};
  Params prior_mean{};  // the start unless the problem names another
  TangentBasis basis, trial_basis;
  bool at_start = true;  // the pending evaluation is of the start
  bool converged = false;
  bool parked = false;  // the pending evaluation is the uncertainty's, at the solution
  // The last step's normal equations invert, so its observations' leverages exist. Where they do
  // not, the pixel's 1σ is undetermined (NaN): its uncertainty's matrices would be summed or not
  // as its batch-mates need theirs, so a value would depend on which pixels shared its batch.
  bool leverages = false;
  double cost = 0, data_cost = 0, squares = 0, cost_resolution = 0;
  Vector12 jtr = Vector12::Zero();
  Matrix12 jtj = Matrix12::Zero();    // data + prior
  Matrix12 bread = Matrix12::Zero();  // Σ ψ'(r) g gᵀ (+ the prior)
  Matrix12 meat = Matrix12::Zero();   // Σ ψ(r)² g gᵀ
  double predicted_decrease = 0;
  double radius = kInitialRadius, decrease_factor = 2;
  double step_scaled_norm = 0;                                // the last trial step's length in the Jacobi-scaled space
  double max_step = std::numeric_limits<double>::infinity();  // on the next trial step's scaled length
  double step_slope = 0;                                      // the cost's slope along the last trial step
  int iterations = 0, used = 0;
  double inverse_scale = 1;
};

struct Evaluation {
  double cost, data_cost, squares, cost_resolution;
  Vector12 jtr;
  Matrix12 jtj, bread, meat;
};

Evaluation ReadLane(const internal::LaneEquations& eq, int p, const Prior& prior, const Params& x, const TangentBasis& basis,
                    const Params& start) {
  Evaluation e;
  e.data_cost = eq.cost[p];
  e.squares = eq.squares[p];
  e.cost_resolution = eq.cost_resolution[p];
  for (int i = 0; i < kTangentParams; ++i) {
    e.jtr[i] = eq.jtr[i][p];
    for (int j = i; j < kTangentParams; ++j) {
      e.jtj(i, j) = e.jtj(j, i) = eq.jtj[internal::NormalIndex(i, j)][p];
      e.bread(i, j) = e.bread(j, i) = eq.bread[internal::NormalIndex(i, j)][p];
      e.meat(i, j) = e.meat(j, i) = eq.meat[internal::NormalIndex(i, j)][p];
    }
  }
  e.cost = e.data_cost;
  if (prior.active()) {
    const Vector12 d = prior.Difference(x, basis, start);
    e.cost += 0.5 * d.dot(prior.precision.cwiseProduct(d));
    e.jtr += prior.precision.cwiseProduct(d);
    e.jtj.diagonal() += prior.precision;
    e.bread.diagonal() += prior.precision;
  }
  return e;
}

bool Frozen(const Lane& lane, int i, const RefineOptions& options) {
  if (i == kF0 && options.fixed_f0) return true;
  const std::optional<Bounds> bounds = BoundsOf(i, options.min_sigma);
  if (!bounds) return false;
  const double value = lane.x[Ambient(i)];
  return (value <= bounds->lower && lane.jtr[i] > 0) || (value >= bounds->upper && lane.jtr[i] < 0);
}

// x ⊞ δ, projected onto the bounds; returns the step actually taken, per tangent parameter.
Vector12 Move(const Params& x, const TangentBasis& basis, const Vector12& delta, double min_sigma, Params& moved) {
  moved = x;
  const Eigen::Vector3d n = Eigen::Vector3d(x[0], x[1], x[2]).normalized() + delta[0] * basis.u + delta[1] * basis.v;
  const Eigen::Vector3d unit = n.normalized();
  moved[0] = unit.x(), moved[1] = unit.y(), moved[2] = unit.z();
  Vector12 taken = delta;
  for (int i = 2; i < kTangentParams; ++i) {
    double value = x[Ambient(i)] + delta[i];
    if (const std::optional<Bounds> bounds = BoundsOf(i, min_sigma)) value = std::clamp(value, bounds->lower, bounds->upper);
    moved[Ambient(i)] = value;
    taken[i] = value - x[Ambient(i)];
  }
  return taken;
}

// max |x − Π(x − g)|: Ceres' gradient test, with the bounds' projection.
double ProjectedGradientNorm(const Lane& lane, const RefineOptions& options) {
  double largest = 0;
  for (int i = 0; i < kTangentParams; ++i) {
    if (i == kF0 && options.fixed_f0) continue;
    double change = lane.jtr[i];
    if (const std::optional<Bounds> bounds = BoundsOf(i, options.min_sigma)) {
      const double value = lane.x[Ambient(i)];
      change = value - std::clamp(value - lane.jtr[i], bounds->lower, bounds->upper);
    }
    largest = std::max(largest, std::abs(change));
  }
  return largest;
}

enum class StepOutcome { kReady, kConverged, kFailed };

// The damped step from the lane's current state into lane.trial.
StepOutcome ComputeStep(Lane& lane, const RefineOptions& options) {
  for (;;) {
    // Ceres' Jacobi scaling: columns scaled by 1 / (1 + |J_i|), so that the normal derivatives,
    // albedos and σ (whose columns differ by orders of magnitude) meet the Cholesky solve and the
    // damping on an equal footing.
    const Vector12 scale = (1 + lane.jtj.diagonal().array().sqrt()).inverse();
    Matrix12 a = scale.asDiagonal() * lane.jtj * scale.asDiagonal();
    Vector12 g = scale.cwiseProduct(lane.jtr);
    for (int i = 0; i < kTangentParams; ++i) a(i, i) += std::clamp(a(i, i), kMinDiagonal, kMaxDiagonal) / lane.radius;
    for (int i = 0; i < kTangentParams; ++i) {
      if (!Frozen(lane, i, options)) continue;
      a.row(i).setZero();
      a.col(i).setZero();
      a(i, i) = 1;
      g[i] = 0;
    }
    const Eigen::LLT<Matrix12> llt(a);
    Vector12 scaled = llt.info() == Eigen::Success ? Vector12(llt.solve(-g)) : Vector12::Constant(NAN);
    if (scaled.norm() > lane.max_step) scaled *= lane.max_step / scaled.norm();
    const Vector12 delta = scale.cwiseProduct(scaled);
    if (delta.allFinite()) {
      const Vector12 taken = Move(lane.x, lane.basis, delta, options.min_sigma, lane.trial);
      double x_norm = 0;
      for (double v : lane.x) x_norm += v * v;
      if (taken.norm() <= options.parameter_tolerance * (std::sqrt(x_norm) + options.parameter_tolerance)) {
        return StepOutcome::kConverged;
      }
      lane.step_slope = taken.dot(lane.jtr);
      lane.predicted_decrease = -(lane.step_slope + 0.5 * taken.dot(lane.jtj * taken));
      lane.step_scaled_norm = taken.cwiseQuotient(scale).norm();
      if (lane.predicted_decrease > 0) {
        lane.trial_basis = BasisOf(lane.trial);
        return StepOutcome::kReady;
      }
    }
    // No usable step at this damping: shrink the trust region, as after a rejected step.
    lane.radius /= lane.decrease_factor;
    lane.decrease_factor *= 2;
    if (lane.radius < kMinRadius) return StepOutcome::kConverged;
  }
}

// Where along a rejected step (as a fraction of it) the parabola through the cost at its start,
// the slope there and the cost at its end has its minimum, bounded to the retreat's range.
double RetreatFraction(const Lane& lane, double rejected_cost) {
  const double curvature = rejected_cost - lane.cost - lane.step_slope;
  const double minimum = curvature > 0 ? -lane.step_slope / (2 * curvature) : kRetreatMax;
  return std::clamp(minimum, kRetreatMin, kRetreatMax);
}

void Accept(Lane& lane, const Evaluation& e) {
  lane.cost = e.cost;
  lane.data_cost = e.data_cost;
  lane.squares = e.squares;
  lane.cost_resolution = e.cost_resolution;
  lane.bread = e.bread;
  lane.meat = e.meat;
  lane.jtr = e.jtr;
  lane.jtj = e.jtj;
}

// The sandwich covariance H⁻¹ M H⁻¹ · m/(m − p) of an M-estimator (H = Σ ψ' g gᵀ, M = Σ ψ² g gᵀ
// with each term divided by 1 − its leverage, HC2; White's, with its small-sample factor): the
// noise of a scan is not the same on every observation — a highlight's is many times a dark
// view's — and the plain s² H⁻¹ then understates the normal's and σ's error and overstates
// the albedos' (measured: 1σ covered 23 % of normal errors, 100 % of a_d's).
// The inverse of `m` over the free parameters (zero rows and columns for a held F0); NaN where
// it is singular.
Matrix12 FreeInverse(const Matrix12& m, const RefineOptions& options) {
  std::vector<int> free;
  for (int i = 0; i < kTangentParams; ++i) {
    if (!(i == kF0 && options.fixed_f0)) free.push_back(i);
  }
  const int n = static_cast<int>(free.size());
  Eigen::MatrixXd h(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) h(i, j) = m(free[i], free[j]);
  }
  Matrix12 inverse = Matrix12::Zero();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(h);
  if (!(ldlt.info() == Eigen::Success && ldlt.isPositive() && ldlt.vectorD().minCoeff() > 0)) {
    return Matrix12::Constant(NAN);
  }
  const Eigen::MatrixXd free_inverse = ldlt.solve(Eigen::MatrixXd::Identity(n, n));
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) inverse(free[i], free[j]) = free_inverse(i, j);
  }
  return inverse;
}

ParamSigma SigmaOf(const Lane& lane, const RefineOptions& options) {
  const int n = kTangentParams - (options.fixed_f0 ? 1 : 0);
  const double small_sample = static_cast<double>(lane.used) / std::max(1, lane.used - n);
  const Matrix12 inverse = FreeInverse(lane.bread, options);
  const Matrix12 covariance =
      inverse.allFinite() ? Matrix12(inverse * lane.meat * inverse * small_sample) : Matrix12::Constant(NAN);
  const auto sd = [&](int i) { return std::sqrt(std::max(0.0, covariance(i, i))); };
  ParamSigma s;
  const double deg = 180 / kPi;
  s.normal_deg = std::sqrt(std::max(0.0, covariance(0, 0) + covariance(1, 1))) * deg;
  if (std::isnan(covariance(0, 0))) s.normal_deg = NAN;
  for (int c = 0; c < 3; ++c) {
    s.a_d[c] = std::isnan(covariance(2 + c, 2 + c)) ? NAN : sd(2 + c);
    s.a_s[c] = std::isnan(covariance(5 + c, 5 + c)) ? NAN : sd(5 + c);
  }
  s.sigma_x = std::isnan(covariance(8, 8)) ? NAN : sd(8);
  s.sigma_y = std::isnan(covariance(9, 9)) ? NAN : sd(9);
  s.alpha_deg = std::isnan(covariance(kAlpha, kAlpha)) ? NAN : sd(kAlpha) * deg;
  return s;
}

ParamSigma UndeterminedSigma() {
  ParamSigma s;
  s.normal_deg = s.sigma_x = s.sigma_y = s.alpha_deg = NAN;
  s.a_d = s.a_s = Eigen::Vector3d::Constant(NAN);
  return s;
}

Params ClampedStart(const WardParams<double>& start, const RefineOptions& options) {
  Params x = Pack(start);
  const Eigen::Vector3d n = Eigen::Vector3d(x[0], x[1], x[2]).normalized();
  x[0] = n.x(), x[1] = n.y(), x[2] = n.z();
  if (options.fixed_f0) x[12] = *options.fixed_f0;
  for (int i = 2; i < kTangentParams; ++i) {
    if (const std::optional<Bounds> b = BoundsOf(i, options.min_sigma)) {
      x[Ambient(i)] = std::clamp(x[Ambient(i)], b->lower, b->upper);
    }
  }
  return x;
}

// One worker: kLanes pixels in flight, each finished one replaced by the next from `next`.
class Batch {
 public:
  Batch(const RefineProblem& problem, const RefineOptions& options, std::vector<RefinedPixel>& results, std::atomic<int>& next,
        std::atomic<int>& done)
      : problem_(problem),
        options_(options),
        prior_(options.prior),
        results_(results),
        next_(next),
        done_(done),
        data_(problem.lights_per_observation),
        park_in_place_(data_.slots() >= kInPlaceSlotsPerObservation * data_.observations),
        parked_data_(park_in_place_ ? std::vector<int>{} : problem.lights_per_observation) {
    inputs_.huber_scale = parked_inputs_.huber_scale = options.huber_scale;
    parked_inputs_.normal_equations = false;  // the parked pixels' steps are done
    // A lane that never holds a pixel still runs through the kernel: give it finite parameters
    // (zeros would make n_s NaN, which sends libmvec's whole vector down its scalar path).
    for (internal::LaneInputs* inputs : {&inputs_, &parked_inputs_}) {
      const Params harmless = Pack(WardParams<double>{});
      const TangentBasis basis = BasisOf(harmless);
      for (int p = 0; p < kLanes; ++p) {
        for (int i = 0; i < kAmbientParams; ++i) inputs->params[i][p] = harmless[i];
        for (int c = 0; c < 3; ++c) inputs->tangent[0][c][p] = basis.u[c], inputs->tangent[1][c][p] = basis.v[c];
        inputs->inverse_scale[p] = 1;
      }
    }
  }

  void Run() {
    for (int p = 0; p < kLanes; ++p) Refill(p);
    while (std::any_of(lanes_.begin(), lanes_.end(), [](const Lane& l) { return l.pixel >= 0; })) {
      internal::EvaluateLanes(data_, inputs_, equations_);
      for (int p = 0; p < kLanes; ++p) {
        if (lanes_[p].pixel < 0) continue;
        if (lanes_[p].parked) {
          Finish(lanes_[p], equations_, p);
          inputs_.leverage[p] = 0;
          Refill(p);
        } else {
          Advance(p);
        }
      }
    }
    EvaluateParked();
  }

 private:
  // Loads the next pixel with enough observations into lane p (or leaves it idle).
  void Refill(int p) {
    Lane& lane = lanes_[p];
    lane.pixel = -1;
    for (int pixel = next_++; pixel < problem_.pixels; pixel = next_++) {
      problem_.observations(pixel, observations_);
      const internal::UsableObservations usable = internal::Usable(observations_);
      const WardParams<double> start = problem_.start(pixel);
      if (static_cast<int>(usable.observations.size()) < kNumWardParams) {
        results_[pixel] = {start, 0, 0, static_cast<int>(usable.observations.size()), 0, false, false, {}};
        ++done_;
        continue;
      }
      lane = Lane{};
      lane.pixel = pixel;
      lane.used = static_cast<int>(usable.observations.size());
      lane.inverse_scale = internal::LoadLane(usable, p, data_);
      lane.start = ClampedStart(start, options_);
      lane.x = lane.trial = lane.start;
      lane.prior_mean = problem_.prior_mean ? ClampedStart(problem_.prior_mean(pixel), options_) : lane.start;
      lane.basis = lane.trial_basis = BasisOf(lane.x);
      SetInputs(p);
      return;
    }
    data_.ClearLane(p);
  }

  void SetInputs(int p) {
    const Lane& lane = lanes_[p];
    for (int i = 0; i < kAmbientParams; ++i) inputs_.params[i][p] = lane.trial[i];
    for (int c = 0; c < 3; ++c) {
      inputs_.tangent[0][c][p] = lane.trial_basis.u[c];
      inputs_.tangent[1][c][p] = lane.trial_basis.v[c];
    }
    inputs_.inverse_scale[p] = lane.inverse_scale;
  }

  // One LM decision for lane p from the evaluation of its trial point.
  void Advance(int p) {
    Lane& lane = lanes_[p];
    const Evaluation e = ReadLane(equations_, p, prior_, lane.trial, lane.trial_basis, lane.prior_mean);
    bool converged = false;
    if (lane.at_start) {
      lane.at_start = false;
      Accept(lane, e);
    } else {
      ++lane.iterations;
      const double decrease = lane.cost - e.cost;
      const double ratio = decrease / lane.predicted_decrease;
      // A change within both costs' rounding (the kernel sums in float) is no change: Ceres'
      // relative function tolerance alone would keep a noise-free fit stepping on rounding.
      const bool unresolved = std::abs(decrease) <= lane.cost_resolution + e.cost_resolution;
      if (std::isfinite(e.cost) && ratio > kMinRelativeDecrease) {
        const double old_cost = lane.cost;
        lane.x = lane.trial;
        lane.basis = lane.trial_basis;
        Accept(lane, e);
        lane.radius = std::min(kMaxRadius, lane.radius / std::max(1.0 / 3, 1 - std::pow(2 * ratio - 1, 3)));
        if (std::abs(ratio - 1) < kGoodModel) lane.radius = std::min(kMaxRadius, kExtraGrowth * lane.radius);
        lane.decrease_factor = 2;
        lane.max_step = std::numeric_limits<double>::infinity();
        converged = unresolved || std::abs(decrease) <= options_.function_tolerance * old_cost;
      } else {
        lane.radius /= lane.decrease_factor;
        lane.decrease_factor *= 2;
        if (std::isfinite(e.cost)) lane.max_step = RetreatFraction(lane, e.cost) * lane.step_scaled_norm;
        converged = unresolved || lane.radius < kMinRadius;
      }
    }
    converged = converged || ProjectedGradientNorm(lane, options_) <= options_.gradient_tolerance;
    if (!converged && lane.iterations < options_.max_iterations) {
      const StepOutcome step = ComputeStep(lane, options_);
      if (step == StepOutcome::kReady) {
        SetInputs(p);
        return;
      }
      converged = step == StepOutcome::kConverged;
    }
    Park(p, converged);
  }

  // A finished pixel needs one more evaluation, at its solution, with each observation's
  // leverage (HC2) in the uncertainty's meat. That evaluation sums the uncertainty's matrices for
  // all kLanes lanes, so where a pixel's light samples are many (linear light), the pixel stays
  // in its lane for it and its observations are loaded once. Where they are few (point-lit),
  // those sums are most of a call, and finished pixels wait in a batch of their own, copied into
  // it, evaluated together. (A/B, docs/benchmarks.md: the batch's copies, with two batches of
  // light slots in the cache, took a fifth of tac7-mini's first fits; in place, a point-lit fit
  // of 900 observations took an eighth longer.)
  void Park(int p, bool converged) {
    Lane& lane = lanes_[p];
    lane.converged = converged;
    if (!options_.uncertainty) {
      results_[lane.pixel] = Finished(lane, {});
      ++done_;
      Refill(p);
      return;
    }
    if (park_in_place_) {
      lane.parked = true;
      lane.leverages = SetUncertaintyInputs(lane, p, inputs_);
      return;
    }
    const int q = parked_count_++;
    data_.CopyLane(p, parked_data_, q);
    parked_[q] = lane;
    parked_[q].leverages = SetUncertaintyInputs(lane, q, parked_inputs_);
    Refill(p);
    if (parked_count_ == kLanes) EvaluateParked();
  }

  // Index `at` of `inputs` to evaluate `lane` at its solution with its observations' leverages;
  // false where those do not exist (the last step's normal equations are singular).
  bool SetUncertaintyInputs(const Lane& lane, int at, internal::LaneInputs& inputs) const {
    for (int i = 0; i < kAmbientParams; ++i) inputs.params[i][at] = lane.x[i];
    for (int c = 0; c < 3; ++c) {
      inputs.tangent[0][c][at] = lane.basis.u[c];
      inputs.tangent[1][c][at] = lane.basis.v[c];
    }
    inputs.inverse_scale[at] = lane.inverse_scale;
    const Matrix12 inverse = FreeInverse(lane.jtj, options_);  // the hat matrix of the last LM step's
    const bool usable = inverse.allFinite();
    inputs.leverage[at] = usable ? 1 : 0;
    for (int i = 0; i < kTangentParams; ++i) {
      for (int j = i; j < kTangentParams; ++j) {
        inputs.bread_inverse[internal::NormalIndex(i, j)][at] = usable ? inverse(i, j) : 0;
      }
    }
    return usable;
  }

  // The batch of parked pixels' uncertainty evaluation (lanes beyond parked_count_ hold stale,
  // finite data and are ignored).
  void EvaluateParked() {
    if (parked_count_ == 0) return;
    internal::EvaluateLanes(parked_data_, parked_inputs_, parked_equations_);
    for (int q = 0; q < parked_count_; ++q) Finish(parked_[q], parked_equations_, q);
    parked_count_ = 0;
  }

  // The result of a pixel whose evaluation at its solution is index `at` of `equations`.
  void Finish(Lane& lane, const internal::LaneEquations& equations, int at) {
    const Evaluation e = ReadLane(equations, at, prior_, lane.x, lane.basis, lane.prior_mean);
    lane.bread = e.bread;
    lane.meat = e.meat;
    results_[lane.pixel] = Finished(lane, lane.leverages ? SigmaOf(lane, options_) : UndeterminedSigma());
    ++done_;
  }

  static RefinedPixel Finished(const Lane& lane, const ParamSigma& sigma) {
    return {Unpack(lane.x), lane.data_cost, std::sqrt(lane.squares / lane.used), lane.used, lane.iterations, true,
            lane.converged, sigma};
  }

  const RefineProblem& problem_;
  const RefineOptions& options_;
  const Prior prior_;
  std::vector<RefinedPixel>& results_;
  std::atomic<int>& next_;
  std::atomic<int>& done_;
  std::vector<PixelObservation> observations_;  // the last pixel loaded's, its memory reused for the next
  internal::LaneData data_;
  internal::LaneInputs inputs_{};
  internal::LaneEquations equations_{};
  std::array<Lane, kLanes> lanes_;
  const bool park_in_place_;
  internal::LaneData parked_data_;  // empty when parking in place
  internal::LaneInputs parked_inputs_{};
  internal::LaneEquations parked_equations_{};
  std::array<Lane, kLanes> parked_;
  int parked_count_ = 0;
};

}  // namespace

Status RefineOptions::Check() const {
  std::vector<std::string> problems;
  if (max_iterations < 1) problems.push_back("max_iterations must be ≥ 1");
  if (!(huber_scale > 0)) problems.push_back("huber_scale must be > 0");
  if (fixed_f0 && !(*fixed_f0 >= 0 && *fixed_f0 <= 1)) problems.push_back("fixed_f0 must be in [0, 1]");
  if (!(function_tolerance >= 0 && function_tolerance < 1)) problems.push_back("function_tolerance must be in [0, 1)");
  if (!(gradient_tolerance >= 0)) problems.push_back("gradient_tolerance must be ≥ 0");
  if (!(parameter_tolerance >= 0)) problems.push_back("parameter_tolerance must be ≥ 0");
  if (!(prior.weight >= 0)) problems.push_back("prior.weight must be ≥ 0");
  if (!(prior.normal_deg > 0 && prior.diffuse_albedo > 0 && prior.specular_albedo > 0 && prior.sigma > 0 &&
        prior.alpha_deg > 0)) {
    problems.push_back("prior's normal_deg, diffuse_albedo, specular_albedo, sigma and alpha_deg must be > 0");
  }
  if (max_lights_per_observation < 0) problems.push_back("max_lights_per_observation must be ≥ 0");
  if (coarse_lights_per_observation < 0) problems.push_back("coarse_lights_per_observation must be ≥ 0");
  if (threads < 0) problems.push_back("threads must be ≥ 0");
  return ProblemsStatus("RefineOptions", problems);
}

namespace {

// Scores lobe shapes for one pixel on the refiner's kernel, 8 per vectorised call: each with its
// least-squares albedos, from the normal equations summed per colour-weight group.
class GridScorer {
 public:
  GridScorer(const internal::UsableObservations& usable, int max_lights) : usable_(usable), data_(Layout(usable, max_lights)) {
    internal::LoadLane(usable, 0, data_);
    for (int lane = 1; lane < kLanes; ++lane) data_.CopyLane(0, data_, lane);
    diffuse_.resize(data_.observations * kLanes), specular_.resize(data_.observations * kLanes);
    // The albedos' normal equations are Σ over observations of (D², DS, S²) · w wᵀ and (D, S) · y w:
    // observations that share colour weights w (every monochrome one) are summed as scalars first.
    for (const PixelObservation* o : usable.observations) {
      const auto found = std::find(weights_.begin(), weights_.end(), o->rgb_weights);
      group_.push_back(static_cast<int>(found - weights_.begin()));
      if (found == weights_.end()) weights_.push_back(o->rgb_weights);
      squares_ += o->radiance * o->radiance;
    }
    for (const Eigen::Vector3d& w : weights_) outer_.push_back(w * w.transpose());
    sums_.resize(weights_.size());
  }

  // Each candidate with its albedos and its cost.
  std::vector<std::pair<double, WardParams<double>>> Score(const std::vector<WardParams<double>>& candidates) {
    std::vector<std::pair<double, WardParams<double>>> scored;
    for (size_t first = 0; first < candidates.size(); first += kLanes) {
      for (int lane = 0; lane < kLanes; ++lane) {
        const Params x = Pack(candidates[std::min(first + lane, candidates.size() - 1)]);
        for (int i = 0; i < kAmbientParams; ++i) inputs_.params[i][lane] = x[i];
      }
      internal::SumTermsLanes(data_, inputs_, diffuse_.data(), specular_.data());
      SumAcrossObservations();
      for (int lane = 0; lane < kLanes && first + lane < candidates.size(); ++lane) {
        scored.push_back(Solve(lane, candidates[first + lane]));
      }
    }
    return scored;
  }

 private:
  // Σ D², DS, S², D y, S y per group, for the call's kLanes candidates side by side: the kernel
  // writes an observation's lanes next to each other, so the sums run across them.
  using LaneSums = std::array<std::array<double, kLanes>, 5>;

  static std::vector<int> Layout(const internal::UsableObservations& usable, int max_lights) {
    std::vector<int> layout(*std::max_element(usable.slots.begin(), usable.slots.end()) + 1, 0);
    for (size_t u = 0; u < usable.observations.size(); ++u) {
      const int lights = static_cast<int>(usable.observations[u]->lights.size());
      layout[usable.slots[u]] = max_lights > 0 ? std::min(lights, max_lights) : lights;
    }
    return layout;
  }

  void SumAcrossObservations() {
    std::fill(sums_.begin(), sums_.end(), LaneSums{});
    for (size_t u = 0; u < usable_.observations.size(); ++u) {
      const double* d = &diffuse_[static_cast<size_t>(usable_.slots[u]) * kLanes];
      const double* sp = &specular_[static_cast<size_t>(usable_.slots[u]) * kLanes];
      const double y = usable_.observations[u]->radiance;
      LaneSums& sum = sums_[group_[u]];
      for (int lane = 0; lane < kLanes; ++lane) {
        sum[0][lane] += d[lane] * d[lane], sum[1][lane] += d[lane] * sp[lane], sum[2][lane] += sp[lane] * sp[lane];
        sum[3][lane] += d[lane] * y, sum[4][lane] += sp[lane] * y;
      }
    }
  }

  std::pair<double, WardParams<double>> Solve(int lane, WardParams<double> candidate) const {
    Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
    for (size_t g = 0; g < weights_.size(); ++g) {
      normal.topLeftCorner<3, 3>() += sums_[g][0][lane] * outer_[g];
      normal.topRightCorner<3, 3>() += sums_[g][1][lane] * outer_[g];
      normal.bottomRightCorner<3, 3>() += sums_[g][2][lane] * outer_[g];
      rhs.head<3>() += sums_[g][3][lane] * weights_[g];
      rhs.tail<3>() += sums_[g][4][lane] * weights_[g];
    }
    normal.bottomLeftCorner<3, 3>() = normal.topRightCorner<3, 3>().transpose();
    const Eigen::Matrix<double, 6, 1> albedos = internal::SolveAlbedos(normal, rhs);
    candidate.a_d = albedos.head<3>();
    candidate.a_s = albedos.tail<3>();
    return {albedos.dot(normal * albedos) - 2 * albedos.dot(rhs) + squares_, candidate};
  }

  const internal::UsableObservations& usable_;
  internal::LaneData data_;
  internal::LaneInputs inputs_{};
  std::vector<double> diffuse_, specular_;
  std::vector<Eigen::Vector3d> weights_;  // distinct colour weights
  std::vector<int> group_;                // per usable observation: its index in `weights_`
  std::vector<Eigen::Matrix3d> outer_;    // w wᵀ per group
  double squares_ = 0;                    // Σ y²
  std::vector<LaneSums> sums_;
};

}  // namespace

std::vector<WardParams<double>> GridStarts(const std::vector<PixelObservation>& observations, double f0, int count,
                                           int max_lights, int normals_kept) {
  const internal::UsableObservations usable = internal::Usable(observations);
  if (usable.observations.empty()) return {};
  GridScorer scorer(usable, max_lights);
  if (normals_kept <= 0) return internal::Best(scorer.Score(internal::GridCandidates(f0)), count);
  // Coarse to fine: the normals ranked by their best isotropic lobe, every shape at the best few.
  std::vector<std::pair<double, WardParams<double>>> scored = scorer.Score(internal::GridCandidates(f0, true));
  std::vector<Eigen::Vector3d> normals;
  for (const WardParams<double>& p : internal::Best(scored, static_cast<int>(scored.size()))) {
    if (std::none_of(normals.begin(), normals.end(), [&](const Eigen::Vector3d& n) { return n == p.n_s; }))
      normals.push_back(p.n_s);
    if (static_cast<int>(normals.size()) == normals_kept) break;
  }
  std::vector<WardParams<double>> anisotropic;
  for (WardParams<double> candidate : internal::GridCandidates(f0)) {
    if (candidate.sigma_x == candidate.sigma_y) continue;
    if (std::none_of(normals.begin(), normals.end(), [&](const Eigen::Vector3d& n) { return n == candidate.n_s; })) continue;
    anisotropic.push_back(candidate);
  }
  for (auto& s : scorer.Score(anisotropic)) scored.push_back(std::move(s));
  return internal::Best(std::move(scored), count);
}

std::vector<int> LightsPerObservation(const std::vector<std::vector<PixelObservation>>& pixels) {
  std::vector<int> lights;
  for (const std::vector<PixelObservation>& observations : pixels) {
    for (size_t k = 0; k < observations.size(); ++k) {
      const PixelObservation& o = observations[k];
      const size_t slot = o.source >= 0 ? static_cast<size_t>(o.source) : k;
      if (slot >= lights.size()) lights.resize(slot + 1, 0);
      lights[slot] = std::max(lights[slot], static_cast<int>(o.lights.size()));
    }
  }
  return lights;
}

namespace {

std::vector<RefinedPixel> RefineInOnePass(const RefineProblem& problem, const RefineOptions& options,
                                          const std::function<void(int done)>& progress) {
  RefineProblem layout = problem;
  if (options.max_lights_per_observation > 0) {
    for (int& lights : layout.lights_per_observation) lights = std::min(lights, options.max_lights_per_observation);
  }
  std::vector<RefinedPixel> results(problem.pixels);
  std::atomic<int> next{0}, done{0};
  const int workers = std::max(1, std::min(ThreadCount(options.threads), (problem.pixels + kLanes - 1) / kLanes));
  ParallelFor(
      workers, workers, [&](int) { Batch(layout, options, results, next, done).Run(); },
      [&](int) {
        if (progress) progress(done.load());
      });
  return results;
}

// Whether a coarse pass would evaluate fewer light samples than the fine one somewhere.
bool CoarsensSomething(const RefineProblem& problem, const RefineOptions& options) {
  const int coarse = options.coarse_lights_per_observation;
  const int fine = options.max_lights_per_observation > 0 ? options.max_lights_per_observation : std::numeric_limits<int>::max();
  return coarse > 0 && coarse < fine &&
         std::any_of(problem.lights_per_observation.begin(), problem.lights_per_observation.end(),
                     [&](int lights) { return lights > coarse; });
}

}  // namespace

Result<std::vector<RefinedPixel>> RefinePixels(const RefineProblem& problem, const RefineOptions& options,
                                               const std::function<void(int done)>& progress) {
  LOOM_RETURN_IF_ERROR(options.Check());
  if (problem.pixels < 0 || !problem.observations || !problem.start) {
    return InvalidArgumentError("refine problem", "needs a pixel count ≥ 0, observations and starts");
  }
  RefineOptions fine_options = options;
  fine_options.coarse_lights_per_observation = 0;
  if (!CoarsensSomething(problem, options)) return RefineInOnePass(problem, fine_options, progress);

  RefineOptions coarse_options = fine_options;
  coarse_options.max_lights_per_observation = options.coarse_lights_per_observation;
  const std::vector<RefinedPixel> coarse = RefineInOnePass(problem, coarse_options, [&](int done) {
    if (progress) progress(done / 2);
  });
  RefineProblem fine = problem;
  fine.start = [&](int i) { return coarse[i].params; };
  fine.prior_mean = problem.prior_mean ? problem.prior_mean : problem.start;  // still the caller's, not the coarse fit
  std::vector<RefinedPixel> results = RefineInOnePass(fine, fine_options, [&](int done) {
    if (progress) progress((problem.pixels + done) / 2);
  });
  for (int i = 0; i < problem.pixels; ++i) results[i].iterations += coarse[i].iterations;
  return results;
}

std::string RefinerInstructionSet() { return internal::RefineKernelIsa(); }

}  // namespace loom::fitting
