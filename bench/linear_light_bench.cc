// How many point emitters the linear light needs in a fit (issue #21, item 3): the radiance of a
// linear-light observation with the strip as N point emitters (the midpoint rule, as the stack's
// table and the simulator sample it) against a converged reference of 4096, on tac7-mini's
// geometry (the strip at 70 positions, both cameras, 25 points of the sample) for the
// parameters of procedural fabrics (seeds 1–8, 8 × 8 px each). Not timed: the cost of a fit is
// proportional to the emitters (docs/benchmarks.md).
//
//   bench_linear_light --json=linear_light.json
//
// Five forms: the strip sampled at N points; the stack's 32 emitters merged into N
// (fitting::MergeLightSamples, what the refiner does with max_lights_per_observation = N);
// merged per observation by the lobe's width (StripSamplesFor), the diffuse term kept over all 32;
// the continuous strip by composite Gauss–Legendre; and by Gauss–Legendre split at the lobe
// (fitting/model/strip_quadrature.h, `loom fit --strip-nodes`).
// Per N and form: the relative radiance error |L_N − L_ref| / L_ref of every observation whose L_ref is at
// least 1 % of its pixel's mean (p50, p99, max), and the error relative to the pixel's mean
// radiance, the unit the fit's residuals are in (p99, max); diffuse and specular alike.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iostream>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/rig_file.h"
#include "core/rig_observation.h"
#include "core/testing/build_tree.h"
#include "fitting/model/strip_quadrature.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/solve/batch_refiner.h"
#include "fitting/solve/pixel_fitter.h"
#include "sim/fabric.h"

namespace {

using loom::fitting::LightSample;
using loom::fitting::PixelObservation;
using loom::fitting::WardParams;

constexpr int kReferenceEmitters = 4096;
constexpr int kStripPositions = 70;

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * (values.size() - 1))];
}

// The error columns of a row: the relative errors of the observations at least 1 % of their
// pixel's mean, and every observation's error relative to its pixel's mean.
nlohmann::json ErrorColumns(const std::vector<double>& relative, const std::vector<double>& of_mean) {
  return {{"relative_error_p50", Quantile(relative, 0.5)},     {"relative_error_p99", Quantile(relative, 0.99)},
          {"relative_error_max", Quantile(relative, 1.0)},     {"error_of_pixel_mean_p99", Quantile(of_mean, 0.99)},
          {"error_of_pixel_mean_max", Quantile(of_mean, 1.0)}, {"observations", relative.size()}};
}

// Every linear-light observation of point p (flat: local frame = sample frame) with the strip as
// `emitters` point sources.
std::vector<PixelObservation> StripObservations(loom::RigModel rig, int emitters, const Eigen::Vector3d& p) {
  rig.linear_light->segments = emitters;
  std::vector<PixelObservation> observations;
  for (int k = 0; k < kStripPositions; ++k) {
    loom::LightingState lighting;
    lighting.linear_light_on = true;
    lighting.linear_light_intensity = 1;
    lighting.linear_light_mm = rig.linear_light->travel_mm * k / (kStripPositions - 1);
    for (int camera = 0; camera < static_cast<int>(rig.cameras.size()); ++camera) {
      const auto described = loom::DescribeRigObservation(rig, camera, lighting);
      LOOM_CHECK(described.ok()) << described.status().ToString();
      PixelObservation o;
      o.v_local = (described->camera_mm - p).normalized();
      o.rgb_weights = described->rgb_weights;
      for (const loom::PointEmitter& e : described->emitters) {
        const Eigen::Vector3d to_light = e.position_mm - p;
        o.lights.push_back({to_light.normalized(), e.IntensityTowards(p) / to_light.squaredNorm()});
      }
      observations.push_back(std::move(o));
    }
  }
  return observations;
}

// The lobe-adaptive form (tried for issue #21 and rejected, docs/benchmarks.md): how many samples
// an observation's strip needs for a lobe no narrower than `sigma`. The lobe falls off as
// exp(−θ_h²/σ²) in the halfway vector's angle, a Gaussian of width σ/√2, and the midpoint rule
// on a Gaussian on an unbounded line is exact up to ~2·exp(−2π² w²) with w samples per width;
// runs of 2^k emitters are merged while the halfway vector moves at most σ / (√2 · w) across one.
int StripSamplesFor(const PixelObservation& observation, double sigma, double samples_per_width) {
  const std::vector<LightSample>& lights = observation.lights;
  const int n = static_cast<int>(lights.size());
  if (n <= 1) return n;
  double widest_step = 0;
  Eigen::Vector3d previous = (lights[0].l_local + observation.v_local).normalized();
  for (int i = 1; i < n; ++i) {
    const Eigen::Vector3d h = (lights[i].l_local + observation.v_local).normalized();
    widest_step = std::max(widest_step, std::acos(std::clamp(h.dot(previous), -1.0, 1.0)));
    previous = h;
  }
  const double run = sigma / (std::sqrt(2.0) * samples_per_width);
  int merged_per_sample = 1;
  while (n % (2 * merged_per_sample) == 0 && 2 * merged_per_sample * widest_step <= run) merged_per_sample *= 2;
  return n / merged_per_sample;
}

// The light samples of `emitters` at point p (flat: local frame = sample frame).
std::vector<LightSample> LightsAt(const std::vector<loom::PointEmitter>& emitters, const Eigen::Vector3d& p) {
  std::vector<LightSample> lights;
  for (const loom::PointEmitter& e : emitters) {
    const Eigen::Vector3d to_light = e.position_mm - p;
    lights.push_back({to_light.normalized(), e.IntensityTowards(p) / to_light.squaredNorm()});
  }
  return lights;
}

// The strip of every linear-light observation of StripObservations' order, from its 32 emitters.
std::vector<loom::fitting::StripSegment> Strips(const loom::RigModel& rig) {
  std::vector<loom::fitting::StripSegment> strips;
  for (int k = 0; k < kStripPositions; ++k) {
    loom::LightingState lighting;
    lighting.linear_light_on = true;
    lighting.linear_light_mm = rig.linear_light->travel_mm * k / (kStripPositions - 1);
    for (int camera = 0; camera < static_cast<int>(rig.cameras.size()); ++camera) {
      const auto described = loom::DescribeRigObservation(rig, camera, lighting);
      LOOM_CHECK(described.ok()) << described.status().ToString();
      strips.push_back(*loom::fitting::StripOfEmitters(described->emitters));
    }
  }
  return strips;
}

// The strip as `panels` equal parts of `nodes` Gauss–Legendre nodes each.
std::vector<loom::PointEmitter> CompositeGaussLegendre(const loom::fitting::StripSegment& strip, int panels, int nodes) {
  std::vector<loom::PointEmitter> emitters;
  for (int panel = 0; panel < panels; ++panel) {
    for (const auto& [x, weight] : loom::fitting::GaussLegendreRule(nodes)) {
      const double u = (panel + (1 + x) / 2) / panels;
      emitters.push_back(
          {strip.At(u), strip.axis, strip.intensity_per_mm * strip.LengthMm() / panels / 2 * weight, strip.falloff_exponent});
    }
  }
  return emitters;
}

}  // namespace

int main(int argc, char** argv) {
  std::string json_path = "linear_light.json";
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--json=", 7) == 0) json_path = argv[i] + 7;
  }
  const auto loaded = loom::LoadRigModel(loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml");
  LOOM_CHECK(loaded.ok()) << loaded.status().ToString();
  const loom::RigModel& rig = *loaded;
  std::vector<WardParams<double>> materials;
  for (uint64_t seed = 1; seed <= 8; ++seed) {
    const loom::sim::Material fabric = loom::sim::GenerateFabric(seed, {.width_px = 8, .height_px = 8, .pixel_mm = 0.2});
    for (int y = 0; y < 8; y += 2) {
      for (int x = 0; x < 8; x += 2) materials.push_back(loom::fitting::GetParams(fabric.maps, x, y));
    }
  }
  const std::vector<int> counts = {2, 4, 6, 8, 12, 16, 24, 32, 64};
  std::vector<Eigen::Vector3d> points;
  for (double x : {-4.0, -2.0, 0.0, 2.0, 4.0}) {
    for (double y : {-4.0, -2.0, 0.0, 2.0, 4.0}) points.push_back({x, y, 0});
  }
  nlohmann::json rows = nlohmann::json::array();
  for (const bool merged : {false, true}) {
    for (int count : counts) {
      if (merged && count > 32) continue;
      std::vector<double> relative, of_mean;
      for (size_t m = 0; m < materials.size(); ++m) {
        const Eigen::Vector3d& p = points[m % points.size()];
        const loom::fitting::WardLobe<double> lobe(materials[m]);
        const std::vector<PixelObservation> reference = StripObservations(rig, kReferenceEmitters, p);
        std::vector<PixelObservation> coarse = StripObservations(rig, merged ? 32 : count, p);
        if (merged) {
          for (PixelObservation& o : coarse) o.lights = loom::fitting::MergeLightSamples(o.lights, count);
        }
        std::vector<double> exact(reference.size());
        double mean = 0;
        for (size_t k = 0; k < reference.size(); ++k) mean += (exact[k] = PredictRadiance(lobe, reference[k])) / reference.size();
        for (size_t k = 0; k < reference.size(); ++k) {
          const double error = std::abs(PredictRadiance(lobe, coarse[k]) - exact[k]);
          of_mean.push_back(error / mean);
          if (exact[k] >= 0.01 * mean) relative.push_back(error / exact[k]);
        }
      }
      rows.push_back({{"form", merged ? "32 merged" : "sampled"}, {"emitters", count}});
      rows.back().update(ErrorColumns(relative, of_mean));
      std::cout << rows.back().dump() << std::endl;
    }
  }
  // The adaptive form: the diffuse term over all 32 emitters (the refiner's closed form), the
  // lobe over StripSamplesFor's count for the material's narrower σ; error against the
  // reference and against the 32 emitters themselves (the stack's model).
  for (const double samples_per_width : {0.75, 1.0, 1.5, 2.0}) {
    std::vector<double> relative, of_mean, against_model, counts_used;
    for (size_t m = 0; m < materials.size(); ++m) {
      const Eigen::Vector3d& p = points[m % points.size()];
      WardParams<double> diffuse_only = materials[m], lobe_only = materials[m];
      diffuse_only.a_s.setZero();
      lobe_only.a_d.setZero();
      const double narrower = std::min(materials[m].sigma_x, materials[m].sigma_y);
      const std::vector<PixelObservation> reference = StripObservations(rig, kReferenceEmitters, p);
      const std::vector<PixelObservation> model = StripObservations(rig, 32, p);
      std::vector<double> exact(reference.size());
      double mean = 0;
      const loom::fitting::WardLobe<double> lobe(materials[m]);
      for (size_t k = 0; k < reference.size(); ++k) mean += (exact[k] = PredictRadiance(lobe, reference[k])) / reference.size();
      for (size_t k = 0; k < reference.size(); ++k) {
        PixelObservation merged = model[k];
        const int count = StripSamplesFor(model[k], narrower, samples_per_width);
        counts_used.push_back(count);
        merged.lights = loom::fitting::MergeLightSamples(model[k].lights, count);
        const double adaptive = PredictRadiance(loom::fitting::WardLobe<double>(diffuse_only), model[k]) +
                                PredictRadiance(loom::fitting::WardLobe<double>(lobe_only), merged);
        const double error = std::abs(adaptive - exact[k]);
        of_mean.push_back(error / mean);
        against_model.push_back(std::abs(adaptive - PredictRadiance(lobe, model[k])) / mean);
        if (exact[k] >= 0.01 * mean) relative.push_back(error / exact[k]);
      }
    }
    double mean_count = 0;
    for (double c : counts_used) mean_count += c / counts_used.size();
    rows.push_back({{"form", "adaptive"},
                    {"samples_per_width", samples_per_width},
                    {"emitters", mean_count},
                    {"against_32_of_pixel_mean_p99", Quantile(against_model, 0.99)},
                    {"against_32_of_pixel_mean_max", Quantile(against_model, 1.0)}});
    rows.back().update(ErrorColumns(relative, of_mean));
    std::cout << rows.back().dump() << std::endl;
  }
  // Gauss–Legendre on the continuous strip: composite (equal panels), and split at the lobe as the
  // refiner's `loom fit --strip-nodes` places its nodes (fitting/model/strip_quadrature.h: the lobe's
  // span scanned at the 32 emitters, the parts beside it). Nodes per observation against the
  // same reference.
  struct GaussForm {
    const char* name;
    int panels;  // composite: equal panels; split: nodes per side part
    int nodes;   // per panel; split: in the lobe's span
  };
  const std::vector<GaussForm> gauss_forms = {{"gauss-legendre", 1, 16}, {"gauss-legendre", 2, 8}, {"gauss-legendre", 4, 4},
                                              {"gauss-legendre", 4, 6},  {"gauss-legendre", 8, 4}, {"lobe-split", 2, 4},
                                              {"lobe-split", 2, 6},      {"lobe-split", 3, 8},     {"lobe-split", 3, 10},
                                              {"lobe-split", 4, 12}};
  const std::vector<loom::fitting::StripSegment> strips = Strips(rig);
  for (const GaussForm& form : gauss_forms) {
    const bool split = std::strcmp(form.name, "lobe-split") == 0;
    loom::fitting::StripQuadratureOptions quadrature;
    quadrature.side_nodes = form.panels;
    quadrature.lobe_nodes = form.nodes;
    std::vector<double> relative, of_mean, counts_used;
    for (size_t m = 0; m < materials.size(); ++m) {
      const Eigen::Vector3d& p = points[m % points.size()];
      const loom::fitting::WardLobe<double> lobe(materials[m]);
      const std::vector<PixelObservation> reference = StripObservations(rig, kReferenceEmitters, p);
      const std::vector<PixelObservation> model = StripObservations(rig, 32, p);  // the lobe is scanned at the 32
      std::vector<double> exact(reference.size());
      double mean = 0;
      for (size_t k = 0; k < reference.size(); ++k) mean += (exact[k] = PredictRadiance(lobe, reference[k])) / reference.size();
      for (size_t k = 0; k < reference.size(); ++k) {
        std::vector<loom::PointEmitter> nodes;
        if (split) {
          std::vector<Eigen::Vector3d> l_local;
          for (const LightSample& l : model[k].lights) l_local.push_back(l.l_local);
          const auto span = loom::fitting::LobeSpan(l_local, model[k].v_local, materials[m], quadrature.lobe_fraction);
          nodes = loom::fitting::StripNodes(strips[k], {0.0, 1.0}, span, quadrature);
        } else {
          nodes = CompositeGaussLegendre(strips[k], form.panels, form.nodes);
        }
        counts_used.push_back(static_cast<double>(nodes.size()));
        PixelObservation integrated = reference[k];
        integrated.lights = LightsAt(nodes, p);
        const double error = std::abs(PredictRadiance(lobe, integrated) - exact[k]);
        of_mean.push_back(error / mean);
        if (exact[k] >= 0.01 * mean) relative.push_back(error / exact[k]);
      }
    }
    double mean_count = 0;
    for (double c : counts_used) mean_count += c / counts_used.size();
    rows.push_back({{"form", form.name},
                    {split ? "side_nodes" : "panels", form.panels},
                    {split ? "lobe_nodes" : "nodes_per_panel", form.nodes},
                    {"emitters", mean_count}});
    rows.back().update(ErrorColumns(relative, of_mean));
    std::cout << rows.back().dump() << std::endl;
  }
  const nlohmann::json out = {
      {"bench", "linear_light"},
      {"description", "linear-light radiance with the strip as N point emitters vs 4096, tac7-mini, fabric parameters"},
      {"reference_emitters", kReferenceEmitters},
      {"materials", materials.size()},
      {"results", rows}};
  std::ofstream(json_path) << out.dump(2) << "\n";
  std::cout << "wrote " << json_path << "\n";
  return 0;
}
