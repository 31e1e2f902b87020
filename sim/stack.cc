#include "sim/stack.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <thread>

#include "core/check.h"
#include "core/spectra.h"

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

namespace {

// The colour weights of a lit LED: through its wheel's filter if one is in, else panchromatic.
Eigen::Vector3d LedWeights(const RigModel& rig, const SceneState& state, int led) {
  for (size_t w = 0; w < rig.filter_wheels.size(); ++w) {
    const auto slot = state.filter_slots.find(static_cast<int>(w));
    const FilterWheelModel& wheel = rig.filter_wheels[w];
    if (wheel.led == led && slot != state.filter_slots.end() && slot->second >= 0 &&
        slot->second < static_cast<int>(wheel.filters.size())) {
      return FilterWeights(wheel.filters[slot->second]);
    }
  }
  return PanchromaticWeights();
}

std::string Describe(const RigModel& rig, const Observation& o) {
  std::ostringstream out;
  out << rig.cameras.at(o.camera).name << ", turntable " << o.state.turntable_deg << " deg";
  for (const LitLed& led : o.state.leds) out << ", led " << led.led << " at " << led.current_ma << " mA";
  for (const auto& [wheel, slot] : o.state.filter_slots) {
    const FilterModel& filter = rig.filter_wheels.at(wheel).filters.at(slot);
    out << ", " << rig.filter_wheels.at(wheel).name << " slot " << slot << " (";
    if (filter.open) {
      out << "open)";
    } else {
      out << filter.center_nm << " nm)";
    }
  }
  if (o.state.linear_light_on) out << ", linear light at " << o.state.linear_light_mm << " mm";
  return out.str();
}

}  // namespace

StackObservation DescribeObservation(const RigModel& rig, const Observation& observation) {
  const SceneState& state = observation.state;
  const Rigid3d sample_from_rig = rig.turntable.RigFromSample(state.turntable_deg).inverse();
  StackObservation o;
  o.camera = rig.cameras.at(observation.camera).name;
  o.camera_mm = sample_from_rig * rig.cameras.at(observation.camera).CentreInRig();
  o.turntable_deg = state.turntable_deg;
  o.rgb_weights = PanchromaticWeights();
  o.description = Describe(rig, observation);
  bool weights_set = false;
  for (const LitLed& lit : state.leds) {
    const LedModel& led = rig.leds.at(lit.led);
    const Eigen::Vector3d weights = LedWeights(rig, state, lit.led);
    LOOM_CHECK(!weights_set || weights == o.rgb_weights) << "observation mixes LEDs of different colour: " << o.description;
    o.rgb_weights = weights;
    weights_set = true;
    o.emitters.push_back({sample_from_rig * led.position_mm, sample_from_rig.linear() * led.axis,
                          led.intensity * lit.current_ma / 1000.0, led.falloff_exponent});
  }
  o.group = o.rgb_weights == PanchromaticWeights() ? ObservationGroup::kMonochrome : ObservationGroup::kColour;
  if (rig.linear_light && state.linear_light_on && state.linear_light_intensity > 0) {
    LOOM_CHECK(!weights_set || o.rgb_weights == PanchromaticWeights()) << "linear light with a filtered LED: " << o.description;
    o.group = ObservationGroup::kLinearLight;
    const LinearLightModel& strip = *rig.linear_light;
    const Eigen::Vector3d centre = strip.StripCentre(state.linear_light_mm);
    const Eigen::Vector3d normal = sample_from_rig.linear() * strip.StripNormal(state.linear_light_mm);
    const double segment_mm = strip.strip_length_mm / strip.segments;
    for (int k = 0; k < strip.segments; ++k) {
      const Eigen::Vector3d source = centre + strip.sweep_axis * ((k + 0.5) * segment_mm - strip.strip_length_mm / 2);
      o.emitters.push_back({sample_from_rig * source, normal,
                            strip.intensity_per_mm * segment_mm * state.linear_light_intensity, strip.falloff_exponent});
    }
  }
  return o;
}

ObservationStack RenderStack(const Scene& scene, const std::vector<Observation>& observations, const StackOptions& options) {
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
          for (size_t o = 0; o < observations.size(); ++o) {
            const Observation& observation = observations[o];
            const Rigid3d sample_from_rig = rig.turntable.RigFromSample(observation.state.turntable_deg).inverse();
            const Eigen::Vector3d eye = sample_from_rig * rig.cameras.at(observation.camera).CentreInRig();
            // Seen only if the camera's ray to p meets the surface at p, not before it.
            const std::optional<Eigen::Vector3d> hit = scene.Intersect(eye, (p - eye).normalized());
            const bool visible = hit && (*hit - p).norm() < 0.5 * material.pixel_mm;
            stack.at(6 + static_cast<int>(o), y, x) =
                visible ? static_cast<float>(scene.RadianceAt(p, eye, observation.state, options.shadows))
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
