#include "core/rig_observation.h"

#include <sstream>

#include "core/spectra.h"

namespace loom {
namespace {

// The colour weights of a lit LED: through its wheel's filter if the wheel is at a known slot.
Eigen::Vector3d LedWeights(const RigModel& rig, const LightingState& lighting, int led) {
  for (size_t w = 0; w < rig.filter_wheels.size(); ++w) {
    const FilterWheelModel& wheel = rig.filter_wheels[w];
    const auto slot = lighting.filter_slots.find(static_cast<int>(w));
    if (wheel.led == led && slot != lighting.filter_slots.end() && slot->second >= 0 &&
        slot->second < static_cast<int>(wheel.filters.size())) {
      return FilterWeights(wheel.filters[slot->second]);
    }
  }
  return PanchromaticWeights();
}

std::string Describe(const RigModel& rig, int camera, const LightingState& lighting) {
  std::ostringstream out;
  out << rig.cameras.at(camera).name << ", turntable " << lighting.turntable_deg << " deg";
  for (const auto& [led, current_ma] : lighting.leds) out << ", led " << led << " at " << current_ma << " mA";
  for (const auto& [wheel, slot] : lighting.filter_slots) {
    const FilterModel& filter = rig.filter_wheels.at(wheel).filters.at(slot);
    out << ", " << rig.filter_wheels.at(wheel).name << " slot " << slot << " (";
    if (filter.open) {
      out << "open)";
    } else {
      out << filter.center_nm << " nm)";
    }
  }
  if (lighting.linear_light_on) out << ", linear light at " << lighting.linear_light_mm << " mm";
  return out.str();
}

Status CheckIndices(const RigModel& rig, int camera, const LightingState& lighting) {
  const std::string what = "observation of rig '" + rig.name + "'";
  if (camera < 0 || camera >= static_cast<int>(rig.cameras.size())) {
    return OutOfRangeError(what, "no camera " + std::to_string(camera));
  }
  for (const auto& [led, current_ma] : lighting.leds) {
    if (led < 0 || led >= static_cast<int>(rig.leds.size())) return OutOfRangeError(what, "no LED " + std::to_string(led));
  }
  for (const auto& [wheel, slot] : lighting.filter_slots) {
    if (wheel < 0 || wheel >= static_cast<int>(rig.filter_wheels.size()) || slot < 0 ||
        slot >= static_cast<int>(rig.filter_wheels[wheel].filters.size())) {
      return OutOfRangeError(what, "no filter wheel " + std::to_string(wheel) + " slot " + std::to_string(slot));
    }
  }
  if (lighting.linear_light_on && !rig.linear_light) {
    return FailedPreconditionError(what, "the linear light is on, the rig has none");
  }
  return {};
}

}  // namespace

Result<StackObservation> DescribeRigObservation(const RigModel& rig, int camera, const LightingState& lighting) {
  LOOM_RETURN_IF_ERROR(CheckIndices(rig, camera, lighting));
  const Rigid3d sample_from_rig = rig.turntable.RigFromSample(lighting.turntable_deg).inverse();
  StackObservation o;
  o.camera = rig.cameras[camera].name;
  o.camera_mm = sample_from_rig * rig.cameras[camera].CentreInRig();
  o.turntable_deg = lighting.turntable_deg;
  o.rgb_weights = PanchromaticWeights();
  o.description = Describe(rig, camera, lighting);
  bool weights_set = false;
  for (const auto& [index, current_ma] : lighting.leds) {
    const LedModel& led = rig.leds[index];
    const Eigen::Vector3d weights = LedWeights(rig, lighting, index);
    if (weights_set && weights != o.rgb_weights) {
      return InvalidArgumentError(o.description, "the image mixes LEDs of different colour");
    }
    o.rgb_weights = weights;
    weights_set = true;
    o.emitters.push_back({sample_from_rig * led.position_mm, sample_from_rig.linear() * led.axis,
                          led.intensity * current_ma / 1000.0, led.falloff_exponent});
  }
  o.group = o.rgb_weights == PanchromaticWeights() ? ObservationGroup::kMonochrome : ObservationGroup::kColour;
  if (lighting.linear_light_on && lighting.linear_light_intensity > 0) {
    if (o.group == ObservationGroup::kColour) {
      return InvalidArgumentError(o.description, "the linear light is on with a filtered LED");
    }
    o.group = ObservationGroup::kLinearLight;
    const LinearLightModel& strip = *rig.linear_light;
    const Eigen::Vector3d centre = strip.StripCentre(lighting.linear_light_mm);
    const Eigen::Vector3d normal = sample_from_rig.linear() * strip.StripNormal(lighting.linear_light_mm);
    const double segment_mm = strip.strip_length_mm / strip.segments;
    for (int k = 0; k < strip.segments; ++k) {
      const double along_mm = strip.SegmentOffsetMm(k);
      o.emitters.push_back({sample_from_rig * (centre + strip.sweep_axis * along_mm), normal,
                            strip.intensity_per_mm * strip.ProfileAt(along_mm) * segment_mm * lighting.linear_light_intensity,
                            strip.falloff_exponent});
    }
  }
  return o;
}

}  // namespace loom
