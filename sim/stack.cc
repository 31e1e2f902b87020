#include "sim/stack.h"

#include <cmath>
#include <limits>
#include <thread>

#include "core/check.h"
#include "core/rig_observation.h"
#include "sim/internal/grid_check.h"

namespace loom::sim {
std::vector<Observation> DefaultObservations(const RigModel& rig, const std::vector<double>& turntable_deg) {
  std::vector<Observation> observations;
  for (double angle : turntable_deg) {
    for (int camera = 0; camera < static_cast<int>(rig.cameras.size()); ++camera) {
      for (int led = 0; led < static_cast<int>(rig.leds.size()); ++led) {
        observations.push_back({camera, {.leds = {{led, 1000}}, .turntable_deg = angle}});
      }
    }
  }
  for (int wheel = 0; wheel < static_cast<int>(rig.filter_wheels.size()); ++wheel) {
    for (int slot = 0; slot < static_cast<int>(rig.filter_wheels[wheel].filters.size()); ++slot) {
      if (rig.filter_wheels[wheel].filters[slot].open) continue;
      for (int camera = 0; camera < static_cast<int>(rig.cameras.size()); ++camera) {
        observations.push_back({camera, {.leds = {{rig.filter_wheels[wheel].led, 1000}}, .filter_slots = {{wheel, slot}}}});
      }
    }
  }
  return observations;
}

StackObservation DescribeObservation(const RigModel& rig, const Observation& observation) {
  const SceneState& state = observation.state;
  LightingState lighting;
  for (const LitLed& lit : state.leds) lighting.leds.emplace_back(lit.led, lit.current_ma);
  lighting.filter_slots = state.filter_slots;
  lighting.turntable_deg = state.turntable_deg;
  lighting.linear_light_on = state.linear_light_on;
  lighting.linear_light_mm = state.linear_light_mm;
  lighting.linear_light_intensity = state.linear_light_intensity;
  Result<StackObservation> described = DescribeRigObservation(rig, observation.camera, lighting);
  LOOM_CHECK(described.ok()) << described.status().ToString();
  return *std::move(described);
}

Status StackOptions::Check() const {
  std::vector<std::string> problems;
  internal::AddGridProblems(width_px, height_px, pixel_mm, /*zero_is_default=*/true, problems);
  if (threads < 0) problems.push_back("threads must be ≥ 0");
  return ProblemsStatus("StackOptions", problems);
}

ObservationStack RenderStack(const Scene& scene, const std::vector<Observation>& observations, const StackOptions& options) {
  const Status checked = options.Check();
  LOOM_CHECK(checked.ok()) << checked.ToString();
  const Material& material = scene.material();
  const double pixel_mm = options.pixel_mm > 0 ? options.pixel_mm : material.pixel_mm;
  const int width = options.width_px > 0 ? options.width_px : material.width();
  const int height = options.height_px > 0 ? options.height_px : material.height();
  const RigModel& rig = scene.rig();
  std::vector<StackObservation> table;
  for (const Observation& observation : observations) table.push_back(DescribeObservation(rig, observation));
  ObservationStack result = MakeObservationStack(width, height, pixel_mm, std::move(table));
  result.rig = rig.name;
  result.source = "sim fast path";
  Image& stack = result.image;
  // What each observation gives every pixel: the turntable's pose, its lights and the camera's centre.
  std::vector<Scene::PlacedState> poses;
  std::vector<Eigen::Vector3d> eyes;
  for (const Observation& observation : observations) {
    poses.push_back(scene.Place(observation.state));
    eyes.push_back(poses.back().sample_from_rig * rig.cameras.at(observation.camera).CentreInRig());
  }
  const int threads = options.threads > 0 ? options.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      for (int y = t; y < height; y += threads) {
        for (int x = 0; x < width; ++x) {
          const double px = (x + 0.5 - width / 2.0) * pixel_mm;
          const double py = (y + 0.5 - height / 2.0) * pixel_mm;
          const Eigen::Vector3d p(px, py, scene.HeightAt(px, py));
          const Eigen::Vector3d normal = scene.GeometricNormalAt(px, py);
          for (int i = 0; i < 3; ++i) {
            stack.at(i, y, x) = static_cast<float>(p[i]);
            stack.at(3 + i, y, x) = static_cast<float>(normal[i]);
          }
          const Scene::ShadingPoint point = scene.ShadeAt(p);
          for (size_t o = 0; o < observations.size(); ++o) {
            const Eigen::Vector3d& eye = eyes[o];
            // Seen only if the camera's ray to p meets the surface at p, not before it.
            const std::optional<Eigen::Vector3d> hit = scene.Intersect(eye, (p - eye).normalized());
            const bool visible = hit && (*hit - p).norm() < 0.5 * material.pixel_mm;
            stack.at(6 + static_cast<int>(o), y, x) =
                visible ? static_cast<float>(scene.RadianceAt(point, eye, observations[o].state, poses[o], options.shadows))
                        : std::numeric_limits<float>::quiet_NaN();
          }
        }
      }
    });
  }
  for (std::thread& worker : workers) worker.join();
  return result;
}

Material TruthOnStackGrid(const Scene& scene, const StackOptions& options) {
  const Status checked = options.Check();
  LOOM_CHECK(checked.ok()) << checked.ToString();
  const Material& material = scene.material();
  Material truth;
  truth.name = material.name;
  truth.pixel_mm = options.pixel_mm > 0 ? options.pixel_mm : material.pixel_mm;
  truth.provenance = material.provenance;
  const int width = options.width_px > 0 ? options.width_px : material.width();
  const int height = options.height_px > 0 ? options.height_px : material.height();
  truth.maps = Image(width, height, material.maps.channel_names());
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const double px = (x + 0.5 - width / 2.0) * truth.pixel_mm;
      const double py = (y + 0.5 - height / 2.0) * truth.pixel_mm;
      const int mx = static_cast<int>(std::floor(px / material.pixel_mm + material.width() / 2.0));
      const int my = static_cast<int>(std::floor(py / material.pixel_mm + material.height() / 2.0));
      if (mx < 0 || my < 0 || mx >= material.width() || my >= material.height()) continue;
      for (int c = 0; c < truth.maps.num_channels(); ++c) truth.maps.at(c, y, x) = material.maps.at(c, my, mx);
    }
  }
  return truth;
}

}  // namespace loom::sim
