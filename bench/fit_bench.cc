// The per-pixel Ceres fit (fitting/solve/pixel_fitter.h): milliseconds per pixel on one core, with the
// hand-derived Jacobians the fitter uses vs ceres::Jet autodiff (the naive way), on
//  - point900: 900 point-lit observations per pixel (the paper's 348 + 3·100 + 280 order of
//    magnitude), spread over the hemisphere;
//  - linear: 300 point-lit + 100 linear-light observations of 32 emitters each, as tac7-mini's
//    strip is sampled in a stack's observation table.
// Each pixel has its own random anisotropic truth, 1 % noise, and starts where a CNN would put
// it: normal 3° off, albedos ±15 %, σ ±25 %, α ±10° (an autodiff fit from such a
// start took 13 ms/px). F0 held at the truth, as loom fit does.
// Counters: ms_per_pixel, iterations per pixel, recovered (normal within 2°, a_d within 0.03).
//
// The batched refiner (fitting/solve/batch_refiner.h) on the same pixels from the same starts, one
// thread, with cost_vs_ceres = the median over pixels of its final cost / Ceres' (1 = the
// same optimum); and both on fast-path stacks of a procedural fabric (8 × 8 px, 1 % noise, starts
// as above from the truth) with tac7-mini's low-preset observations (88 point-lit, 140 linear-light of 32
// emitters: the main job's stack layout) and tac7's (4 cameras; 280 linear-light).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "bench/bench_report.h"
#include "core/rig_file.h"
#include "core/testing/build_tree.h"
#include "fitting/model/stack_pixels.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/solve/batch_refiner.h"
#include "fitting/solve/pixel_fitter.h"
#include "fitting/testing/near_start.h"
#include "sim/fabric.h"
#include "sim/stack.h"

namespace {

using loom::fitting::LightSample;
using loom::fitting::PixelObservation;
using loom::fitting::WardParams;
using loom::fitting::testing::NearStart;

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
  state.counters["ms_per_pixel"] =
      benchmark::Counter(static_cast<double>(fits) * 1e-3, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["iterations"] = static_cast<double>(iterations) / fits;
  state.counters["recovered"] = static_cast<double>(recovered) / fits;
  state.counters["observations"] = points + lines;
}

BENCHMARK_CAPTURE(BM_Fit, point900_analytic, false, 900, 0)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Fit, point900_autodiff, true, 900, 0)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Fit, linear_analytic, false, 300, 100)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Fit, linear_autodiff, true, 300, 100)->Unit(benchmark::kMillisecond);

// Pixels given as lists, as the refiner takes them.
loom::fitting::RefineProblem ListProblem(const std::vector<std::vector<PixelObservation>>& lists,
                                         const std::vector<WardParams<double>>& starts) {
  return {static_cast<int>(lists.size()),
          loom::fitting::LightsPerObservation(lists),
          [&lists](int i, std::vector<PixelObservation>& into) { into = lists[i]; },
          [&starts](int i) { return starts[i]; },
          {}};
}

double Median(std::vector<double> values) {
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// Median over pixels of the refiner's final cost / Ceres' from the same start.
double CostVsCeres(const std::vector<std::vector<PixelObservation>>& lists, const std::vector<WardParams<double>>& starts,
                   const std::vector<loom::fitting::RefinedPixel>& refined, double f0) {
  std::vector<double> ratios;
  for (size_t i = 0; i < lists.size(); ++i) {
    const auto ceres = loom::fitting::FitPixel(lists[i], starts[i], {.max_iterations = 30, .multi_start = false, .fixed_f0 = f0});
    if (ceres.ok() && ceres->cost > 0) ratios.push_back(refined[i].cost / ceres->cost);
  }
  return ratios.empty() ? NAN : Median(ratios);
}

void BM_Refine(benchmark::State& state, int points, int lines) {
  const std::vector<Pixel> pixels = MakePixels(points, lines);
  std::vector<std::vector<PixelObservation>> lists;
  std::vector<WardParams<double>> starts;
  for (int copy = 0; copy < 4; ++copy) {  // 128 pixels a batch: the lanes' start and end matter little
    for (const Pixel& pixel : pixels) lists.push_back(pixel.observations), starts.push_back(pixel.start);
  }
  loom::fitting::RefineOptions options;
  options.threads = 1;
  options.fixed_f0 = pixels.front().truth.f0;  // RandomTruth's F0 is every pixel's
  const loom::fitting::RefineProblem problem = ListProblem(lists, starts);
  int64_t fits = 0, iterations = 0, recovered = 0;
  std::vector<loom::fitting::RefinedPixel> last;
  for (auto _ : state) {
    auto refined = loom::fitting::RefinePixels(problem, options);
    if (!refined.ok()) {
      state.SkipWithError(refined.status().ToString().c_str());
      return;
    }
    for (size_t i = 0; i < refined->size(); ++i) {
      const WardParams<double>& truth = pixels[i % kPixels].truth;
      const WardParams<double>& p = (*refined)[i].params;
      iterations += (*refined)[i].iterations;
      const double angle = std::acos(std::clamp(p.n_s.dot(truth.n_s), -1.0, 1.0));
      if (angle < 2 * loom::kPi / 180 && (p.a_d - truth.a_d).cwiseAbs().maxCoeff() < 0.03) ++recovered;
    }
    fits += static_cast<int64_t>(refined->size());
    last = std::move(*refined);
  }
  state.SetItemsProcessed(fits);
  state.counters["ms_per_pixel"] =
      benchmark::Counter(static_cast<double>(fits) * 1e-3, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["iterations"] = static_cast<double>(iterations) / fits;
  state.counters["recovered"] = static_cast<double>(recovered) / fits;
  state.counters["observations"] = points + lines;
  state.counters["cost_vs_ceres"] = CostVsCeres(lists, starts, last, *options.fixed_f0);
}

// A fast-path stack of fabric 5 on `rig`'s geometry: its turntable at 0, 120, 240° under every
// LED and filter, and the strip at `strip_positions` positions for every camera.
struct StackCase {
  std::vector<std::vector<PixelObservation>> lists;
  std::vector<WardParams<double>> truths, starts;
  std::vector<int> lights;
  int observations = 0;
};

StackCase MakeStackCase(const std::string& rig_name, int strip_positions) {
  const auto loaded = loom::LoadRigModel(loom::testing::SourceDir() + "/configs/rig/" + rig_name + ".yaml");
  LOOM_CHECK(loaded.ok()) << loaded.status().ToString();
  const loom::RigModel& rig = *loaded;
  const loom::sim::Material fabric = loom::sim::GenerateFabric(5, {.width_px = 8, .height_px = 8, .pixel_mm = 0.2});
  const loom::sim::Scene scene(rig, fabric);
  std::vector<loom::sim::Observation> observations = loom::sim::DefaultObservations(rig, {0, 120, 240});
  for (int k = 0; k < strip_positions; ++k) {
    const double position_mm = rig.linear_light->travel_mm * k / (strip_positions - 1);
    for (int camera = 0; camera < static_cast<int>(rig.cameras.size()); ++camera) {
      observations.push_back({camera, {.linear_light_on = true, .linear_light_mm = position_mm}});
    }
  }
  loom::ObservationStack stack = loom::sim::RenderStack(scene, observations, {});
  // 1 % noise, as the point-lit cases: on noise-free data both fits end at their arithmetic's
  // rounding (the refiner sums in float), where the ratio of final costs says nothing.
  std::mt19937 noise_rng(5);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  for (int channel = loom::kStackGeometryChannels; channel < stack.image.num_channels(); ++channel) {
    for (float& v : stack.image.channel(channel)) v *= 1 + noise(noise_rng);
  }
  const loom::fitting::StackPixels pixels(stack);
  StackCase c;
  c.observations = static_cast<int>(stack.observations.size());
  for (const loom::StackObservation& o : stack.observations) c.lights.push_back(static_cast<int>(o.emitters.size()));
  std::mt19937 rng(3);
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      c.lists.push_back(pixels.Observations(x, y));
      c.truths.push_back(loom::fitting::GetParams(fabric.maps, x, y));
      c.starts.push_back(NearStart(c.truths.back(), rng));
    }
  }
  return c;
}

enum class Solver { kCeres, kRefiner };

// `coarse`: the refiner's coarse_lights_per_observation (0: one pass).
void BM_StackFit(benchmark::State& state, const std::string& rig, int strip_positions, Solver solver, int coarse) {
  const StackCase c = MakeStackCase(rig, strip_positions);
  const double f0 = c.truths.front().f0;  // a fabric's F0 is one per material
  const bool refiner = solver == Solver::kRefiner;
  loom::fitting::RefineOptions options;
  options.threads = 1;
  options.fixed_f0 = f0;
  options.coarse_lights_per_observation = coarse;
  const loom::fitting::RefineProblem problem{static_cast<int>(c.lists.size()),
                                             c.lights,
                                             [&c](int i, std::vector<PixelObservation>& into) { into = c.lists[i]; },
                                             [&c](int i) { return c.starts[i]; },
                                             {}};
  int64_t fits = 0, iterations = 0;
  std::vector<loom::fitting::RefinedPixel> last;
  for (auto _ : state) {
    if (refiner) {
      auto refined = loom::fitting::RefinePixels(problem, options);
      LOOM_CHECK(refined.ok()) << refined.status().ToString();
      for (const auto& r : *refined) iterations += r.iterations;
      last = std::move(*refined);
    } else {
      for (size_t i = 0; i < c.lists.size(); ++i) {
        const auto fit =
            loom::fitting::FitPixel(c.lists[i], c.starts[i], {.max_iterations = 30, .multi_start = false, .fixed_f0 = f0});
        LOOM_CHECK(fit.ok()) << fit.status().ToString();
        iterations += fit->iterations;
      }
    }
    fits += static_cast<int64_t>(c.lists.size());
  }
  state.SetItemsProcessed(fits);
  state.counters["ms_per_pixel"] =
      benchmark::Counter(static_cast<double>(fits) * 1e-3, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["iterations"] = static_cast<double>(iterations) / fits;
  state.counters["observations"] = c.observations;
  if (refiner) state.counters["cost_vs_ceres"] = CostVsCeres(c.lists, c.starts, last, f0);
}

// One F0 for the stack case's 64 pixels fitted jointly with them (FitPixelsSharingF0, one
// thread), each started from its own fit at F0 1 as the stack fitter starts them (SearchF0),
// against BM_StackFit's Ceres fits of the same pixels one by one at the true F0: what fitting
// a material's F0 costs.
void BM_SharedF0(benchmark::State& state, const std::string& rig, int strip_positions) {
  const StackCase c = MakeStackCase(rig, strip_positions);
  const double truth_f0 = c.truths.front().f0;
  std::vector<WardParams<double>> starts;
  for (size_t i = 0; i < c.lists.size(); ++i) {
    WardParams<double> start = c.starts[i];
    start.a_s *= start.f0, start.f0 = 1;
    const auto at_one = loom::fitting::FitPixel(c.lists[i], start, {.max_iterations = 30, .multi_start = false, .fixed_f0 = 1.0});
    LOOM_CHECK(at_one.ok()) << at_one.status().ToString();
    starts.push_back(at_one->params);
  }
  int64_t fits = 0, iterations = 0;
  double f0 = 0;
  for (auto _ : state) {
    const auto fit =
        loom::fitting::FitPixelsSharingF0(c.lists, starts, 1.0, {.max_iterations = 30, .multi_start = false, .fixed_f0 = {}});
    LOOM_CHECK(fit.ok()) << fit.status().ToString();
    iterations += fit->iterations;
    f0 = fit->f0;
    fits += static_cast<int64_t>(c.lists.size());
  }
  state.SetItemsProcessed(fits);
  state.counters["ms_per_pixel"] =
      benchmark::Counter(static_cast<double>(fits) * 1e-3, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["iterations"] = static_cast<double>(iterations) * static_cast<double>(c.lists.size()) / fits;
  state.counters["observations"] = c.observations;
  state.counters["f0_error"] = std::abs(f0 - truth_f0);
}

// Real time: the refiner runs on a worker thread of its own (RefinePixels), Ceres on this one.
BENCHMARK_CAPTURE(BM_Refine, point900, 900, 0)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Refine, linear, 300, 100)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_StackFit, tac7_mini_low_ceres, "tac7-mini", 70, Solver::kCeres, 0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_StackFit, tac7_mini_low_refine, "tac7-mini", 70, Solver::kRefiner, 0)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_StackFit, tac7_mini_low_refine_coarse8, "tac7-mini", 70, Solver::kRefiner, 8)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_StackFit, tac7_low_ceres, "tac7", 70, Solver::kCeres, 0)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_StackFit, tac7_low_refine, "tac7", 70, Solver::kRefiner, 0)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_StackFit, tac7_low_refine_coarse8, "tac7", 70, Solver::kRefiner, 8)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_SharedF0, tac7_low, "tac7", 70)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

int main(int argc, char** argv) {
  return loom::bench::RunBenchmarks(
      argc, argv, "fit",
      "Per-pixel fit of the GD10 Ward model on one core: Ceres with analytic vs autodiff Jacobians, the batched refiner vs "
      "Ceres from the same starts, and one F0 fitted jointly with a stack's pixels vs their fits at the true F0",
      {{"point900_analytic_vs_autodiff", "BM_Fit/point900_analytic/real_time", "BM_Fit/point900_autodiff"},
       {"linear_analytic_vs_autodiff", "BM_Fit/linear_analytic/real_time", "BM_Fit/linear_autodiff"},
       {"point900_refiner_vs_ceres", "BM_Refine/point900/real_time", "BM_Fit/point900_analytic/real_time"},
       {"linear_refiner_vs_ceres", "BM_Refine/linear/real_time", "BM_Fit/linear_analytic/real_time"},
       {"tac7_mini_low_refiner_vs_ceres", "BM_StackFit/tac7_mini_low_refine/real_time",
        "BM_StackFit/tac7_mini_low_ceres/real_time"},
       {"tac7_low_refiner_vs_ceres", "BM_StackFit/tac7_low_refine/real_time", "BM_StackFit/tac7_low_ceres/real_time"},
       {"tac7_mini_low_coarse8_vs_one_pass", "BM_StackFit/tac7_mini_low_refine_coarse8/real_time",
        "BM_StackFit/tac7_mini_low_refine/real_time"},
       {"tac7_low_coarse8_vs_one_pass", "BM_StackFit/tac7_low_refine_coarse8/real_time", "BM_StackFit/tac7_low_refine/real_time"},
       {"tac7_low_shared_f0_vs_ceres_at_the_true_f0", "BM_SharedF0/tac7_low/real_time", "BM_StackFit/tac7_low_ceres/real_time"}});
}
