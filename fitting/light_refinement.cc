#include "fitting/light_refinement.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <Eigen/Dense>

#include "core/duration.h"
#include "core/geometry.h"
#include "core/parallel.h"
#include "fitting/model/stack_pixels.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/model/ward_gd10.h"
#include "fitting/view_selection.h"

namespace loom::fitting {
namespace {

constexpr double kStepRad = DegToRad(0.5);  // the finite difference of a turn
constexpr int kIterations = 4;
// How far a calibration's directions and intensities are from the truth, a priori: a dome's
// chrome-sphere directions err by a degree or two, its intensities by a few per cent. Where the
// pixels say little about a light (the normals of a cylinder span one plane), the prior holds it.
constexpr double kTurnPriorRad = DegToRad(2);
constexpr double kGainPrior = 0.1;

double Square(double x) { return x * x; }

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return RadToDeg(std::atan2(a.cross(b).norm(), a.dot(b))); }

// Two unit vectors perpendicular to `l` and to each other: the axes a light's direction turns on.
std::pair<Eigen::Vector3d, Eigen::Vector3d> Perpendiculars(const Eigen::Vector3d& l) {
  const Eigen::Vector3d helper = std::abs(l.z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d e1 = l.cross(helper).normalized();
  return {e1, l.cross(e1)};
}

Eigen::Vector3d Turned(const Eigen::Vector3d& l, const Eigen::Vector3d& toward, double radians) {
  return (l * std::cos(radians) + toward * std::sin(radians)).normalized();
}

// A view's pixel observations with what predicting them under another light needs.
struct ViewSamples {
  std::vector<WardLobe<double>> lobes;
  std::vector<Eigen::Matrix3d> local_from_sample;
  struct Sample {
    int pixel, channel;
    PixelObservation observation;
  };
  std::vector<Sample> samples;
};

ViewSamples SamplesOf(const ObservationStack& view, const Image& maps) {
  const StackPixels stack_pixels(view);
  ViewSamples v;
  for (int y = 0; y < view.image.height(); ++y) {
    for (int x = 0; x < view.image.width(); ++x) {
      if (IsSkippedPixel(maps, x, y)) continue;
      std::vector<PixelObservation> observations = stack_pixels.Observations(x, y);
      if (observations.empty()) continue;
      const int pixel = static_cast<int>(v.lobes.size());
      v.lobes.emplace_back(GetParams(maps, x, y));
      v.local_from_sample.push_back(stack_pixels.LocalFromSample(x, y));
      for (PixelObservation& o : observations) {
        if (o.lights.size() != 1 || !std::isfinite(o.radiance)) continue;
        v.samples.push_back({pixel, o.source, std::move(o)});
      }
    }
  }
  return v;
}

// Each sample's prediction under a light from `towards` (sample frame) of its stack irradiance.
std::vector<double> PredictUnder(ViewSamples& v, const Eigen::Vector3d& towards) {
  std::vector<double> predicted(v.samples.size());
  for (size_t s = 0; s < v.samples.size(); ++s) {
    ViewSamples::Sample& sample = v.samples[s];
    sample.observation.lights[0].l_local = v.local_from_sample[sample.pixel] * towards;
    predicted[s] = PredictRadiance(v.lobes[sample.pixel], sample.observation);
  }
  return predicted;
}

// Cauchy's scale for residuals: 2.5 robust standard deviations (1.4826 × their median magnitude).
double RobustSpread(const std::vector<double>& residuals) {
  std::vector<double> magnitudes(residuals.size());
  for (size_t s = 0; s < residuals.size(); ++s) magnitudes[s] = std::abs(residuals[s]);
  const auto middle = magnitudes.begin() + static_cast<std::ptrdiff_t>(magnitudes.size() / 2);
  std::nth_element(magnitudes.begin(), middle, magnitudes.end());
  return std::max(2.5 * 1.4826 * *middle, 1e-12);
}

// One Gauss-Newton step from `light` (given: the stack's direction): the change of each gain, then
// the turn along e1 and e2. The residuals are weighted by Cauchy's function of their robust spread
// (a highlight the maps misplace, or a cast shadow, is an outlier here); the prior holds each
// correction's distance from the stack's calibration, in units of the residuals' spread.
Eigen::VectorXd GaussNewtonStep(ViewSamples& v, const LightCorrection& light, const Eigen::Vector3d& given,
                                const Eigen::Vector3d& e1, const Eigen::Vector3d& e2) {
  const Eigen::Vector3d& l = light.towards_light;
  const int channels = static_cast<int>(light.gains.size());
  const std::vector<double> p0 = PredictUnder(v, l), p1 = PredictUnder(v, Turned(l, e1, kStepRad)),
                            p2 = PredictUnder(v, Turned(l, e2, kStepRad));
  std::vector<double> residuals(p0.size());
  for (size_t s = 0; s < p0.size(); ++s)
    residuals[s] = v.samples[s].observation.radiance - light.gains[v.samples[s].channel] * p0[s];
  const double spread = RobustSpread(residuals);
  Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(channels + 2, channels + 2);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(channels + 2), j(channels + 2);
  for (size_t s = 0; s < p0.size(); ++s) {
    const int c = v.samples[s].channel;
    const double u = residuals[s] / spread, weight = 1 / (1 + u * u), g = light.gains[c];
    j.setZero();
    j[c] = p0[s], j[channels] = g * (p1[s] - p0[s]) / kStepRad, j[channels + 1] = g * (p2[s] - p0[s]) / kStepRad;
    normal.selfadjointView<Eigen::Lower>().rankUpdate(j, weight);
    rhs += weight * residuals[s] * j;
  }
  const double noise = spread / 2.5, turn_weight = Square(noise / kTurnPriorRad), gain_weight = Square(noise / kGainPrior);
  const Eigen::Vector2d turned_by(-e1.dot(given), -e2.dot(given));  // the current turn from the given light
  for (int c = 0; c < channels; ++c) {
    normal(c, c) += gain_weight;
    rhs[c] -= gain_weight * (light.gains[c] - 1);
  }
  for (int a = 0; a < 2; ++a) {
    normal(channels + a, channels + a) += turn_weight;
    rhs[channels + a] -= turn_weight * turned_by[a];
  }
  return normal.selfadjointView<Eigen::Lower>().ldlt().solve(rhs);
}

// One view's light, its maps held: a gain per observation and a turn of the direction.
LightCorrection EstimateViewLight(const ObservationStack& stack, const Image& maps, const std::vector<int>& observations) {
  const ObservationStack view = SelectObservations(stack, observations);
  const int channels = static_cast<int>(observations.size());
  const Eigen::Vector3d given = view.observations[0].emitters[0].DirectionFrom(Eigen::Vector3d::Zero());
  LightCorrection correction{observations, given, std::vector<double>(channels, 1.0), 0, 0};
  ViewSamples v = SamplesOf(view, maps);
  correction.pixels = static_cast<int>(v.lobes.size());
  if (correction.pixels < kMinLightPixels) return correction;
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    const auto [e1, e2] = Perpendiculars(correction.towards_light);
    const Eigen::VectorXd step = GaussNewtonStep(v, correction, given, e1, e2);
    if (!step.allFinite()) break;
    for (int c = 0; c < channels; ++c) correction.gains[c] += step[c];
    const Eigen::Vector3d turn = step[channels] * e1 + step[channels + 1] * e2;
    if (turn.norm() > 0) correction.towards_light = Turned(correction.towards_light, turn.normalized(), turn.norm());
  }
  correction.turn_deg = AngleDeg(given, correction.towards_light);
  return correction;
}

// The rotation that takes the stack's directions nearest to the corrected ones (Kabsch).
Eigen::Matrix3d CommonRotation(const std::vector<Eigen::Vector3d>& given, const std::vector<Eigen::Vector3d>& corrected) {
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (size_t v = 0; v < given.size(); ++v) h += given[v] * corrected[v].transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
  return svd.matrixV() * d * svd.matrixU().transpose();
}

// The smallest eigenvalue of the fitted normals' mean n nᵀ (n in the sample frame): 0 where they
// span a plane (a cylinder) or less (a flat sample), 1/4 on a hemisphere seen from above.
double NormalSpread(const ObservationStack& stack, const Image& maps) {
  const StackPixels stack_pixels(stack);
  Eigen::Matrix3d moment = Eigen::Matrix3d::Zero();
  int count = 0;
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) {
      if (IsSkippedPixel(maps, x, y)) continue;
      const Eigen::Vector3d n = stack_pixels.LocalFromSample(x, y).transpose() * GetParams(maps, x, y).n_s;
      moment += n * n.transpose(), ++count;
    }
  }
  if (count == 0) return 0;
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(moment / count).eigenvalues()[0];
}

// The corrections less the rotation and the gain common to them all (the stack's directions
// `given`, one per light).
void TakeOutCommonTurnAndGain(const std::vector<Eigen::Vector3d>& given, LightRefinement& refinement) {
  std::vector<Eigen::Vector3d> corrected;
  double log_gains = 0;
  int gains = 0;
  for (const LightCorrection& c : refinement.lights) {
    corrected.push_back(c.towards_light);
    for (double g : c.gains) log_gains += std::log(std::max(g, 1e-6)), ++gains;
  }
  const Eigen::Matrix3d common = CommonRotation(given, corrected);
  refinement.common_turn_deg = RadToDeg(Eigen::AngleAxisd(common).angle());
  const double mean_gain = gains ? std::exp(log_gains / gains) : 1.0;
  for (size_t v = 0; v < refinement.lights.size(); ++v) {
    LightCorrection& c = refinement.lights[v];
    c.towards_light = (common.transpose() * c.towards_light).normalized();
    c.turn_deg = AngleDeg(given[v], c.towards_light);
    for (double& g : c.gains) g /= mean_gain;
  }
}

}  // namespace

bool HasOnlyDirectionalLights(const ObservationStack& stack) {
  return !stack.observations.empty() &&
         std::all_of(stack.observations.begin(), stack.observations.end(),
                     [](const StackObservation& o) { return o.emitters.size() == 1 && o.emitters[0].at_infinity; });
}

Result<LightRefinement> EstimateLightCorrections(const ObservationStack& stack, const Image& maps, int threads) {
  const auto start = std::chrono::steady_clock::now();
  LightRefinement refinement;
  if (!HasOnlyDirectionalLights(stack)) return refinement;
  if (maps.width() != stack.image.width() || maps.height() != stack.image.height()) {
    return InvalidArgumentError("maps", "not on the stack's grid");
  }
  refinement.normal_spread = NormalSpread(stack, maps);
  if (refinement.normal_spread < kMinNormalSpread) return refinement;
  const std::vector<std::vector<int>> views = StackViews(stack);
  refinement.lights.resize(views.size());
  ParallelFor(static_cast<int>(views.size()), threads,
              [&](int v) { refinement.lights[v] = EstimateViewLight(stack, maps, views[v]); });
  std::vector<Eigen::Vector3d> given;
  for (const std::vector<int>& view : views)
    given.push_back(stack.observations[view[0]].emitters[0].DirectionFrom(Eigen::Vector3d::Zero()));
  TakeOutCommonTurnAndGain(given, refinement);
  refinement.seconds = SecondsSince(start);
  return refinement;
}

ObservationStack WithCorrectedLights(ObservationStack stack, const LightRefinement& refinement) {
  for (const LightCorrection& c : refinement.lights) {
    for (size_t j = 0; j < c.observations.size(); ++j) {
      PointEmitter& e = stack.observations[c.observations[j]].emitters[0];
      e = PointEmitter::AtInfinity(c.towards_light, e.intensity * c.gains[j]);
    }
  }
  return stack;
}

double LightRefinement::MeanTurnDeg() const {
  double sum = 0;
  for (const LightCorrection& c : lights) sum += c.turn_deg;
  return lights.empty() ? 0 : sum / static_cast<double>(lights.size());
}

double LightRefinement::MaxTurnDeg() const {
  double most = 0;
  for (const LightCorrection& c : lights) most = std::max(most, c.turn_deg);
  return most;
}

double LightRefinement::GainSpread() const {
  std::vector<double> logs;
  for (const LightCorrection& c : lights) {
    for (double g : c.gains) logs.push_back(std::log(std::max(g, 1e-6)));
  }
  if (logs.empty()) return 0;
  double mean = 0, squares = 0;
  for (double l : logs) mean += l / static_cast<double>(logs.size());
  for (double l : logs) squares += Square(l - mean) / static_cast<double>(logs.size());
  return std::sqrt(squares);
}

bool LightRefinement::WorthApplying() const {
  return !lights.empty() && (MeanTurnDeg() >= kMinMeanTurnDeg || GainSpread() >= kMinGainSpread);
}

nlohmann::json LightRefinement::ToJson() const {
  nlohmann::json lights_json = nlohmann::json::array();
  for (const LightCorrection& c : lights) {
    lights_json.push_back({{"observations", c.observations},
                           {"towards_light", {c.towards_light.x(), c.towards_light.y(), c.towards_light.z()}},
                           {"gains", c.gains},
                           {"turn_deg", c.turn_deg},
                           {"pixels", c.pixels}});
  }
  return {{"lights", lights_json},
          {"normal_spread", normal_spread},
          {"mean_turn_deg", MeanTurnDeg()},
          {"max_turn_deg", MaxTurnDeg()},
          {"gain_spread", GainSpread()},
          {"applied", WorthApplying()},
          {"common_turn_deg", common_turn_deg},
          {"seconds", seconds}};
}

}  // namespace loom::fitting
