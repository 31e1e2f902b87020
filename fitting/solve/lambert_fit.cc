#include "fitting/solve/lambert_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include <Eigen/Dense>

#include "core/duration.h"
#include "core/parallel.h"
#include "fitting/model/stack_pixels.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/solve/stack_fitter.h"

namespace loom::fitting {
namespace {

// One observation as the Lambertian model sees it: its radiance, colour weights and the light
// samples summed into one irradiance vector.
struct Shading {
  double radiance;
  Eigen::Vector3d weights;
  Eigen::Vector3d irradiance;  // Σ E_j l_j, local frame
};

std::vector<Shading> ShadingOf(const std::vector<PixelObservation>& observations) {
  std::vector<Shading> shading;
  shading.reserve(observations.size());
  for (const PixelObservation& o : observations) {
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    for (const LightSample& light : o.lights) e += light.irradiance * light.l_local;
    if (e.squaredNorm() > 0 && std::isfinite(o.radiance)) shading.push_back({o.radiance, o.rgb_weights, e});
  }
  return shading;
}

double Quantile(std::vector<double> values, double q) {
  const size_t i = std::min(values.size() - 1, static_cast<size_t>(q * static_cast<double>(values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(i), values.end());
  return values[i];
}

// Each observation's shading ratio L_o / ((w_o·ρ)|E_o|), the albedo's chromaticity ρ taken as the
// median of L_o / ((w_o·1)|E_o|) over the observations of the same colour weights: a coloured
// albedo makes one colour's ratios all higher than another's, which says nothing of shadows or
// highlights, and ranked together they would trim by colour: a blue material would keep its red
// observations alone, from which few views' nearly parallel lights find no normal.
std::vector<double> ShadingRatios(const std::vector<Shading>& shading) {
  std::vector<double> ratios(shading.size());
  for (size_t o = 0; o < shading.size(); ++o) {
    ratios[o] = shading[o].radiance / (shading[o].weights.sum() * shading[o].irradiance.norm());
  }
  std::vector<Eigen::Vector3d> colours;
  std::vector<std::vector<size_t>> members;
  for (size_t o = 0; o < shading.size(); ++o) {
    const auto found = std::find(colours.begin(), colours.end(), shading[o].weights);
    if (found == colours.end()) {
      colours.push_back(shading[o].weights);
      members.push_back({o});
    } else {
      members[found - colours.begin()].push_back(o);
    }
  }
  std::vector<double> normalised = ratios;
  for (const std::vector<size_t>& colour : members) {
    std::vector<double> values;
    for (size_t o : colour) values.push_back(ratios[o]);
    const double median = Quantile(values, 0.5);
    if (median > 0) {
      for (size_t o : colour) normalised[o] = ratios[o] / median;
    }
  }
  return normalised;
}

double Predict(const Shading& s, const Eigen::Vector3d& normal, const Eigen::Vector3d& albedo) {
  return s.weights.dot(albedo) / std::numbers::pi * std::max(0.0, normal.dot(s.irradiance));
}

// g = |a| n by least squares at chromaticity `chroma`: the normal and the albedo's size, nothing
// where the kept observations' lights do not determine it or it faces away.
std::optional<double> FitNormalAndSize(const std::vector<Shading>& shading, const std::vector<char>& kept,
                                       const Eigen::Vector3d& chroma, Eigen::Vector3d& normal) {
  Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
  Eigen::Vector3d atb = Eigen::Vector3d::Zero();
  for (size_t o = 0; o < shading.size(); ++o) {
    if (!kept[o]) continue;
    const Eigen::Vector3d row = shading[o].weights.dot(chroma) / std::numbers::pi * shading[o].irradiance;
    ata += row * row.transpose();
    atb += row * shading[o].radiance;
  }
  const Eigen::LDLT<Eigen::Matrix3d> solver(ata);
  if (solver.info() != Eigen::Success || !(solver.rcond() > 1e-10)) return std::nullopt;
  const Eigen::Vector3d g = solver.solve(atb);
  if (!(g.norm() > 0) || !g.allFinite()) return std::nullopt;
  if (g.z() < 0) return std::nullopt;  // a surface seen from behind: the data are not photometric stereo's
  normal = g.normalized();
  return g.norm();
}

// |a| at a held normal by least squares: one unknown, which one lit observation determines.
std::optional<double> FitSize(const std::vector<Shading>& shading, const std::vector<char>& kept, const Eigen::Vector3d& chroma,
                              const Eigen::Vector3d& normal) {
  double squares = 0, product = 0;
  for (size_t o = 0; o < shading.size(); ++o) {
    if (!kept[o]) continue;
    const double row = shading[o].weights.dot(chroma) / std::numbers::pi * std::max(0.0, normal.dot(shading[o].irradiance));
    squares += row * row, product += row * shading[o].radiance;
  }
  if (!(squares > 0)) return std::nullopt;
  return std::max(product / squares, 0.0);
}

// One alternation on the kept observations: the albedo's size |a| at the chromaticity of
// `albedo`, with the normal (g = |a| n) or at the normal held without `fit_normal`, then the albedo
// at that normal. False where they determine neither.
bool AlternateOnce(const std::vector<Shading>& shading, const std::vector<char>& kept, bool fit_normal, Eigen::Vector3d& normal,
                   Eigen::Vector3d& albedo) {
  const Eigen::Vector3d chroma = albedo.sum() > 0 ? Eigen::Vector3d(albedo / albedo.sum() * 3) : Eigen::Vector3d::Ones();
  const std::optional<double> size =
      fit_normal ? FitNormalAndSize(shading, kept, chroma, normal) : FitSize(shading, kept, chroma, normal);
  if (!size) return false;
  // The albedo at that normal: L_o = (w_o · a) s_o, s_o = (n · E_o)/π, by least squares; what the
  // weights leave free (a grey camera sees no colour) keeps the chromaticity it had, the
  // minimal-norm correction of a0 = ρ |a| (Eigen's complete orthogonal decomposition).
  Eigen::Matrix3d wtw = Eigen::Matrix3d::Zero();
  Eigen::Vector3d wtb = Eigen::Vector3d::Zero();
  for (size_t o = 0; o < shading.size(); ++o) {
    if (!kept[o]) continue;
    const double s = std::max(0.0, normal.dot(shading[o].irradiance)) / std::numbers::pi;
    const Eigen::Vector3d row = s * shading[o].weights;
    wtw += row * row.transpose();
    wtb += row * shading[o].radiance;
  }
  const Eigen::Vector3d a0 = chroma * *size;
  Eigen::CompleteOrthogonalDecomposition<Eigen::Matrix3d> decomposition;
  decomposition.setThreshold(1e-9);
  decomposition.compute(wtw);
  const Eigen::Vector3d a = a0 + decomposition.solve(wtb - wtw * a0);
  albedo = a.cwiseMax(0.0);
  return albedo.allFinite();
}

// The fit on the kept observations: two alternations, the second at the first's chromaticity.
bool FitKept(const std::vector<Shading>& shading, const std::vector<char>& kept, bool fit_normal, Eigen::Vector3d& normal,
             Eigen::Vector3d& albedo) {
  return AlternateOnce(shading, kept, fit_normal, normal, albedo) && AlternateOnce(shading, kept, fit_normal, normal, albedo);
}

// The header's rule on one pixel.
std::optional<LambertPixel> FitByRule(const std::vector<PixelObservation>& observations, const LambertFitOptions& options) {
  const std::vector<Shading> shading = ShadingOf(observations);
  const size_t n = shading.size();
  if (static_cast<int>(n) < options.min_observations) return std::nullopt;
  // Rule 1: the middle of the shading ratios.
  const std::vector<double> ratios = ShadingRatios(shading);
  const double low = Quantile(ratios, options.trim_dark), high = Quantile(ratios, options.trim_bright);
  std::vector<char> kept(n);
  for (size_t o = 0; o < n; ++o) kept[o] = ratios[o] >= low && ratios[o] <= high;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(), albedo = Eigen::Vector3d::Zero();
  if (!FitKept(shading, kept, options.fit_normal, normal, albedo)) return std::nullopt;
  // Rule 2: lit side, residuals within the robust spread.
  std::vector<double> residuals(n);
  for (int round = 0; round < options.rounds; ++round) {
    std::vector<double> kept_residuals;
    for (size_t o = 0; o < n; ++o) {
      residuals[o] = shading[o].radiance - Predict(shading[o], normal, albedo);
      if (kept[o]) kept_residuals.push_back(std::abs(residuals[o]));
    }
    if (kept_residuals.empty()) return std::nullopt;
    const double spread = std::max(1.4826 * Quantile(kept_residuals, 0.5), 1e-12);
    std::vector<char> next(n);
    int count = 0;
    for (size_t o = 0; o < n; ++o) {
      const bool lit = normal.dot(shading[o].irradiance.normalized()) >= options.min_cos_light;
      next[o] = lit && std::abs(residuals[o]) <= options.reject_sigmas * spread;
      count += next[o];
    }
    if (count < options.min_observations) break;
    Eigen::Vector3d next_normal = normal, next_albedo = albedo;
    if (!FitKept(shading, next, options.fit_normal, next_normal, next_albedo)) break;
    const bool same = next == kept;
    kept = std::move(next), normal = next_normal, albedo = next_albedo;
    if (same) break;
  }
  LambertPixel pixel{normal, albedo, options.fit_normal, 0, 0};
  double squares = 0, sum = 0;
  for (size_t o = 0; o < n; ++o) {
    if (!kept[o]) continue;
    const double r = shading[o].radiance - Predict(shading[o], normal, albedo);
    squares += r * r, sum += std::abs(shading[o].radiance), ++pixel.observations_used;
  }
  if (pixel.observations_used < options.min_observations) return std::nullopt;
  pixel.rms = sum > 0 ? std::sqrt(squares / pixel.observations_used) / (sum / pixel.observations_used) : 0;
  const WardLobe<double> lobe(AsWardParams(pixel));
  double all_squares = 0, all_sum = 0;
  for (const PixelObservation& o : observations) {
    const double r = PredictRadiance(lobe, o) - o.radiance;
    all_squares += r * r, all_sum += std::abs(o.radiance);
  }
  const double count = static_cast<double>(observations.size());
  pixel.rms_all = all_sum > 0 ? std::sqrt(all_squares / count) / (all_sum / count) : 0;
  return pixel;
}

}  // namespace

Status LambertFitOptions::Check() const {
  std::vector<std::string> problems;
  if (!(trim_dark >= 0 && trim_dark < trim_bright && trim_bright <= 1)) {
    problems.push_back("trim_dark and trim_bright must satisfy 0 ≤ trim_dark < trim_bright ≤ 1");
  }
  if (!(min_cos_light >= 0 && min_cos_light < 1)) problems.push_back("min_cos_light must be in [0, 1)");
  if (!(reject_sigmas > 0)) problems.push_back("reject_sigmas must be > 0");
  if (rounds < 0) problems.push_back("rounds must be ≥ 0");
  if (min_observations < 3) problems.push_back("min_observations must be ≥ 3");
  if (threads < 0) problems.push_back("threads must be ≥ 0");
  return ProblemsStatus("LambertFitOptions", problems);
}

std::optional<LambertPixel> FitLambertPixel(const std::vector<PixelObservation>& observations, const LambertFitOptions& options) {
  std::optional<LambertPixel> pixel = FitByRule(observations, options);
  if (pixel || !options.geometric_normal_fallback || !options.fit_normal) return pixel;
  LambertFitOptions albedo_only = options;
  albedo_only.fit_normal = false;
  return FitByRule(observations, albedo_only);
}

WardParams<double> AsWardParams(const LambertPixel& pixel) {
  WardParams<double> p;
  p.n_s = pixel.normal;
  p.a_d = pixel.albedo.cwiseMin(kMaxAlbedo);
  p.a_s = Eigen::Vector3d::Zero();
  p.sigma_x = p.sigma_y = 0.2;
  p.alpha = 0;
  p.f0 = 1;
  return p;
}

std::vector<std::optional<LambertPixel>> LambertPixels(const ObservationStack& stack, const LambertFitOptions& options) {
  const StackPixels pixels(stack);
  const int width = stack.image.width();
  std::vector<std::optional<LambertPixel>> fits(stack.image.pixel_count());
  ParallelFor(static_cast<int>(fits.size()), options.threads,
              [&](int i) { fits[i] = FitLambertPixel(pixels.Observations(i % width, i / width), options); });
  return fits;
}

Result<LambertFit> FitLambert(const ObservationStack& stack, const LambertFitOptions& options) {
  LOOM_RETURN_IF_ERROR(options.Check());
  const auto start = std::chrono::steady_clock::now();
  const int width = stack.image.width(), height = stack.image.height();
  const std::vector<std::optional<LambertPixel>> fits = LambertPixels(stack, options);
  LambertFit fit;
  fit.pixels = width * height;
  fit.maps = MakeSvbrdfImage(width, height, /*with_height=*/true);
  const auto stack_height = stack.image.channel(2);  // pos.Z
  std::copy(stack_height.begin(), stack_height.end(), fit.maps.channel(*fit.maps.ChannelIndex(kHeightChannel)).begin());
  const int used_channel = fit.maps.AddChannel(kFitObservationsChannel);
  const int rms_channel = fit.maps.AddChannel(kFitRmsChannel);
  for (int i = 0; i < fit.pixels; ++i) {
    const int x = i % width, y = i / width;
    WardParams<double> p;
    p.n_s = p.a_d = p.a_s = Eigen::Vector3d::Constant(NAN);
    p.sigma_x = p.sigma_y = p.alpha = p.f0 = NAN;
    if (fits[i]) {
      ++fit.pixels_fitted;
      fit.pixels_at_albedo_bound += fits[i]->albedo.maxCoeff() > kMaxAlbedo;
      p.n_s = fits[i]->normal;
      p.a_d = fits[i]->albedo.cwiseMin(kMaxAlbedo);
      p.a_s = Eigen::Vector3d::Zero();
      p.sigma_x = p.sigma_y = 1;
      p.alpha = 0;
      p.f0 = 1;
    }
    SetParams(fit.maps, x, y, p);
    fit.maps.at(used_channel, y, x) = fits[i] ? static_cast<float>(fits[i]->observations_used) : 0.0f;
    fit.maps.at(rms_channel, y, x) = fits[i] ? static_cast<float>(fits[i]->rms) : NAN;
  }
  fit.seconds = SecondsSince(start);
  return fit;
}

nlohmann::json LambertFit::ToJson() const {
  return {{"pixels", pixels},
          {"pixels_fitted", pixels_fitted},
          {"pixels_skipped", pixels - pixels_fitted},
          {"pixels_at_albedo_bound", pixels_at_albedo_bound},
          {"pixel_seconds", seconds}};
}

}  // namespace loom::fitting
