// How many point emitters the linear light needs in a fit (issue #21, item 3): the radiance of a
// linear-light observation with the strip as N point emitters (the midpoint rule, as the stack's
// table and the simulator sample it) against a converged reference of 4096, on tac7-mini's
// geometry (the strip at 70 positions, both cameras, 25 points of the sample) for the
// parameters of procedural fabrics (seeds 1–8, 8 × 8 px each). Not timed: the cost of a fit is
// proportional to the emitters (docs/benchmarks.md).
//
//   bench_linear_light --json=linear_light.json
//
// Two forms: the strip sampled at N points, and the stack's 32 emitters merged into N
// (fitting::MergeLightSamples, what the refiner does with max_lights_per_observation = N).
// Per N and form: the relative radiance error |L_N − L_ref| / L_ref of every observation whose L_ref is at
// least 1 % of its pixel's mean (p50, p99, max), and the error relative to the pixel's mean
// radiance, the unit the fit's residuals are in (p99, max); diffuse and specular alike.
#include <algorithm>
#include <cstring>
#include <fstream>
#include <iostream>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/config.h"
#include "core/rig_observation.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/batch_refiner.h"
#include "fitting/pixel_fitter.h"
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

}  // namespace

int main(int argc, char** argv) {
  std::string json_path = "linear_light.json";
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--json=", 7) == 0) json_path = argv[i] + 7;
  }
  auto doc = loom::ConfigDocument::LoadFile(std::string(LOOM_SOURCE_DIR) + "/configs/rig/tac7-mini.yaml", 1);
  LOOM_CHECK(doc.ok()) << doc.status().ToString();
  const loom::RigModel rig = loom::ReadRigModel(doc->root().Child("geometry"));
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
      rows.push_back({{"form", merged ? "32 merged" : "sampled"},
                      {"emitters", count},
                      {"relative_error_p50", Quantile(relative, 0.5)},
                      {"relative_error_p99", Quantile(relative, 0.99)},
                      {"relative_error_max", Quantile(relative, 1.0)},
                      {"error_of_pixel_mean_p99", Quantile(of_mean, 0.99)},
                      {"error_of_pixel_mean_max", Quantile(of_mean, 1.0)},
                      {"observations", relative.size()}});
      std::cout << rows.back().dump() << std::endl;
    }
  }
  const nlohmann::json out = {{"bench", "linear_light"},
                              {"description", "linear-light radiance with the strip as N point emitters vs 4096, tac7-mini, fabric parameters"},
                              {"reference_emitters", kReferenceEmitters},
                              {"materials", materials.size()},
                              {"results", rows}};
  std::ofstream(json_path) << out.dump(2) << "\n";
  std::cout << "wrote " << json_path << "\n";
  return 0;
}
