// The per-pixel Ceres fit (fitting/pixel_fitter.h): milliseconds per pixel on one core, with the
// hand-derived Jacobians the fitter uses vs ceres::Jet autodiff (the naive way), on
//  - point900: 900 point-lit observations per pixel (the paper's 348 + 3·100 + 280 order of
//    magnitude), spread over the hemisphere;
//  - linear: 300 point-lit + 100 linear-light observations of 32 emitters each, as tac7-mini's
//    strip is sampled in a stack's observation table.
// Each pixel has its own random anisotropic truth, 1 % noise, and starts where a CNN would put
// it: normal 3° off, albedos ±15 %, σ ±25 %, α ±10° (shared/docs/build-notes.md measured
// 13 ms/px for the autodiff fit from such a start). F0 held at the truth, as loom fit does.
// Counters: ms_per_pixel, iterations per pixel, recovered (normal within 2°, a_d within 0.03).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "bench/bench_report.h"
#include "fitting/pixel_fitter.h"

namespace {

using loom::fitting::LightSample;
using loom::fitting::PixelObservation;
using loom::fitting::WardParams;

constexpr int kPixels = 32;  // distinct pixels cycled through

struct Pixel {
  WardParams<double> truth, start;
  std::vector<PixelObservation> observations;
};

Eigen::Vector3d Hemisphere(std::mt19937& rng, double max_theta) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  return loom::DirectionFromSpherical(max_theta * std::sqrt(unit(rng)), 2 * loom::kPi * unit(rng));
}

WardParams<double> RandomTruth(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  WardParams<double> p;
  p.n_s = loom::DirectionFromSpherical(0.25 * unit(rng), 2 * loom::kPi * unit(rng));
  p.a_d = Eigen::Vector3d(0.1 + 0.5 * unit(rng), 0.1 + 0.5 * unit(rng), 0.1 + 0.5 * unit(rng));
  p.a_s = Eigen::Vector3d::Constant(0.05 + 0.3 * unit(rng));
  p.sigma_x = 0.05 + 0.25 * unit(rng);
  p.sigma_y = 0.05 + 0.25 * unit(rng);
  p.alpha = (unit(rng) - 0.5) * loom::kPi;
  p.f0 = 0.5;
  return p;
}

WardParams<double> NearStart(const WardParams<double>& truth, std::mt19937& rng) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  WardParams<double> s = truth;
  s.n_s = (truth.n_s + 0.05 * Eigen::Vector3d(gauss(rng), gauss(rng), 0)).normalized();
  s.a_d = (truth.a_d.array() * (1 + 0.15 * gauss(rng))).matrix();
  s.a_s = (truth.a_s.array() * (1 + 0.15 * gauss(rng))).matrix();
  s.sigma_x *= 1 + 0.25 * gauss(rng);
  s.sigma_y *= 1 + 0.25 * gauss(rng);
  s.alpha += 0.17 * gauss(rng);
  return s;
}

// Observations of `truth`: `points` point-lit, `lines` of `emitters_per_line` each.
Pixel MakePixel(std::mt19937& rng, int points, int lines, int emitters_per_line) {
  std::normal_distribution<double> noise(0.0, 0.01);
  std::uniform_int_distribution<int> channel(0, 3);
  const Eigen::Vector3d weights[] = {{1.0 / 3, 1.0 / 3, 1.0 / 3}, {0.9, 0.1, 0}, {0.05, 0.9, 0.05}, {0, 0.1, 0.9}};
  Pixel pixel;
  pixel.truth = RandomTruth(rng);
  pixel.start = NearStart(pixel.truth, rng);
  const loom::fitting::WardLobe<double> lobe(pixel.truth);
  for (int k = 0; k < points + lines; ++k) {
    PixelObservation o;
    o.v_local = Hemisphere(rng, 1.1);
    o.rgb_weights = weights[channel(rng)];
    const int emitters = k < points ? 1 : emitters_per_line;
    for (int e = 0; e < emitters; ++e) o.lights.push_back({Hemisphere(rng, 1.2), 1.0 / emitters});
    o.radiance = PredictRadiance(lobe, o) * (1 + noise(rng));
    pixel.observations.push_back(std::move(o));
  }
  return pixel;
}

std::vector<Pixel> MakePixels(int points, int lines) {
  std::mt19937 rng(7);
  std::vector<Pixel> pixels;
  for (int i = 0; i < kPixels; ++i) pixels.push_back(MakePixel(rng, points, lines, 32));
  return pixels;
}

void BM_Fit(benchmark::State& state, bool automatic, int points, int lines) {
  const std::vector<Pixel> pixels = MakePixels(points, lines);
  loom::fitting::PixelFitOptions options;
  options.multi_start = false;
  options.max_iterations = 30;  // what loom fit's per-pixel stage allows
  options.automatic_derivatives = automatic;
  int64_t fits = 0, iterations = 0, recovered = 0;
  for (auto _ : state) {
    const Pixel& pixel = pixels[fits % kPixels];
    options.fixed_f0 = pixel.truth.f0;
    const auto result = loom::fitting::FitPixel(pixel.observations, pixel.start, options);
    if (!result.ok()) {
      state.SkipWithError(result.status().ToString().c_str());
      return;
    }
    ++fits;
    iterations += result->iterations;
    const double angle = std::acos(std::clamp(result->params.n_s.dot(pixel.truth.n_s), -1.0, 1.0));
    if (angle < 2 * loom::kPi / 180 && (result->params.a_d - pixel.truth.a_d).cwiseAbs().maxCoeff() < 0.03) ++recovered;
  }
  state.SetItemsProcessed(fits);
  state.counters["ms_per_pixel"] = benchmark::Counter(static_cast<double>(fits) * 1e-3, benchmark::Counter::kIsRate |
                                                                                         benchmark::Counter::kInvert);
  state.counters["iterations"] = static_cast<double>(iterations) / fits;
  state.counters["recovered"] = static_cast<double>(recovered) / fits;
  state.counters["observations"] = points + lines;
}

BENCHMARK_CAPTURE(BM_Fit, point900_analytic, false, 900, 0)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Fit, point900_autodiff, true, 900, 0)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Fit, linear_analytic, false, 300, 100)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Fit, linear_autodiff, true, 300, 100)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  return loom::bench::RunBenchmarks(
      argc, argv, "fit", "Per-pixel Ceres fit of the GD10 Ward model on one core: analytic vs autodiff Jacobians",
      {{"point900_analytic_vs_autodiff", "BM_Fit/point900_analytic", "BM_Fit/point900_autodiff"},
       {"linear_analytic_vs_autodiff", "BM_Fit/linear_analytic", "BM_Fit/linear_autodiff"}});
}
