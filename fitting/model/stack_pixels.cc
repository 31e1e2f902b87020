#include "fitting/model/stack_pixels.h"

#include <algorithm>
#include <cmath>

#include "core/check.h"
#include "core/geometry.h"
#include "fitting/model/internal/light_samples.h"

namespace loom::fitting {

StackPixels::StackPixels(const ObservationStack& stack, const StackPixelOptions& options) : stack_(stack), options_(options) {
  const auto heights = stack.image.channel(2);  // pos.Z
  heightmap_ =
      Heightmap(std::vector<float>(heights.begin(), heights.end()), stack.image.width(), stack.image.height(), stack.pixel_mm);
  shadow_reach_mm_ = 4 * (stack.image.width() + stack.image.height()) * stack.pixel_mm + 4 * heightmap_.max_height_mm();
  for (const StackObservation& o : stack.observations) {
    directional_.push_back(
        std::any_of(o.emitters.begin(), o.emitters.end(), [](const PointEmitter& e) { return e.at_infinity; }));
    strips_.push_back(o.group == ObservationGroup::kLinearLight ? StripOfEmitters(o.emitters) : std::nullopt);
    emitter_arrays_.emplace_back(o.emitters);
  }
  if (options_.keep_frames) {
    frame_filled_ = std::make_unique<std::once_flag[]>(stack.image.pixel_count());
    frames_.resize(stack.image.pixel_count());
    hidden_.resize(stack.image.pixel_count());
    for (const StackObservation& o : stack.observations)
      first_emitter_bit_.push_back(emitter_bits_), emitter_bits_ += o.emitters.size();
  }
}

Eigen::Matrix3d StackPixels::LocalFromSample(int x, int y) const {
  return WorldFromLocal(stack_.Normal(x, y), Eigen::Vector3d::UnitX()).transpose();
}

StackPixels::PixelFrame StackPixels::FrameOf(int x, int y) const {
  if (!options_.keep_frames) return ComputeFrame(x, y);
  const size_t i = static_cast<size_t>(y) * width() + x;
  std::call_once(frame_filled_[i], [&] {
    frames_[i] = ComputeFrame(x, y);
    if (options_.cast_shadows) hidden_[i] = HiddenEmitters(x, y, frames_[i]);
  });
  return frames_[i];
}

std::vector<uint64_t> StackPixels::HiddenEmitters(int x, int y, const PixelFrame& frame) const {
  std::vector<uint64_t> hidden((emitter_bits_ + 63) / 64, 0);
  for (size_t k = 0; k < stack_.observations.size(); ++k) {
    if (std::isnan(stack_.image.at(ObservationStack::ObservationChannel(static_cast<int>(k)), y, x))) continue;
    const std::vector<PointEmitter>& emitters = stack_.observations[k].emitters;
    for (size_t i = 0; i < emitters.size(); ++i) {
      const size_t bit = first_emitter_bit_[k] + i;
      if (heightmap_.Shadowed(frame.position, emitters[i].ShadowTarget(frame.position, shadow_reach_mm_), frame.horizon))
        hidden[bit / 64] |= uint64_t{1} << (bit % 64);
    }
  }
  return hidden;
}

StackPixels::PixelFrame StackPixels::ComputeFrame(int x, int y) const {
  const Eigen::Vector3d position = stack_.Position(x, y);
  Heightmap::Horizon horizon;
  if (options_.cast_shadows) horizon = heightmap_.HorizonAt(position);
  return {position, LocalFromSample(x, y), horizon};
}

std::vector<PixelObservation> StackPixels::Observations(int x, int y) const {
  std::vector<PixelObservation> observations;
  ObservationsInto(x, y, nullptr, observations);
  return observations;
}

std::vector<PixelObservation> StackPixels::Observations(int x, int y, std::span<const int> only) const {
  std::vector<PixelObservation> observations;
  const PixelFrame frame = FrameOf(x, y);
  for (int k : only) {
    PixelObservation observation;
    if (Observe(k, x, y, frame, observation)) observations.push_back(std::move(observation));
  }
  return observations;
}

std::vector<PixelObservation> StackPixels::Observations(int x, int y, const WardParams<double>& lobe) const {
  std::vector<PixelObservation> observations;
  ObservationsInto(x, y, &lobe, observations);
  return observations;
}

void StackPixels::ObservationsInto(int x, int y, const WardParams<double>* lobe, std::vector<PixelObservation>& into) const {
  if (!integrates_strips()) lobe = nullptr;
  const PixelFrame frame = FrameOf(x, y);
  size_t used = 0;
  for (size_t k = 0; k < stack_.observations.size(); ++k) {
    if (used == into.size()) into.emplace_back();
    if (Observe(static_cast<int>(k), x, y, frame, into[used], lobe)) ++used;
  }
  into.resize(used);
}

std::vector<std::pair<double, double>> StackPixels::LobeSpans(int x, int y, const WardParams<double>& params,
                                                              double fraction) const {
  LOOM_CHECK(integrates_strips()) << "LobeSpans needs StackPixelOptions::strip_quadrature";
  const PixelFrame frame = FrameOf(x, y);
  std::vector<std::pair<double, double>> spans(stack_.observations.size(), {0.0, 1.0});
  std::vector<Eigen::Vector3d> l_local;
  for (size_t k = 0; k < spans.size(); ++k) {
    if (!strips_[k]) continue;
    const StackObservation& o = stack_.observations[k];
    l_local.clear();
    for (const PointEmitter& e : o.emitters)
      l_local.push_back(frame.local_from_sample * (e.position_mm - frame.position).normalized());
    const Eigen::Vector3d v_local = frame.local_from_sample * o.ViewFrom(frame.position);
    spans[k] = LobeSpan(l_local, v_local, params, fraction);
  }
  return spans;
}

bool StackPixels::Observe(int k, int x, int y, const PixelFrame& frame, PixelObservation& observation,
                          const WardParams<double>* lobe) const {
  const float radiance = stack_.image.at(ObservationStack::ObservationChannel(k), y, x);
  if (std::isnan(radiance)) return false;
  const StackObservation& o = stack_.observations[k];
  const Eigen::Vector3d& p = frame.position;
  observation.radiance = radiance;
  observation.v_local = frame.local_from_sample * o.ViewFrom(p);
  observation.rgb_weights = o.rgb_weights;
  observation.source = k;
  const bool integrate = lobe && strips_[k];  // lobe: only from Observations(x, y, lobe), with the option set
  const auto shadowed = [&](const PointEmitter& emitter) {
    return options_.cast_shadows && heightmap_.Shadowed(p, emitter.ShadowTarget(p, shadow_reach_mm_), frame.horizon);
  };
  // Emitter i of the stack's: from the kept bits where there are some.
  const uint64_t* hidden =
      options_.keep_frames && options_.cast_shadows ? hidden_[static_cast<size_t>(y) * width() + x].data() : nullptr;
  const auto hides = [&](int i) {
    if (!hidden) return shadowed(o.emitters[i]);
    const size_t bit = first_emitter_bit_[k] + i;
    return ((hidden[bit / 64] >> (bit % 64)) & 1) != 0;
  };
  std::vector<PointEmitter> nodes;
  bool nodes_lit = false;  // every node lights the pixel: no test of each
  if (integrate) {
    // The nodes integrate the strip between the first and the last of the stack's emitters (its
    // midpoints) that light the pixel, cut halfway to their dark neighbours: a shadow's or the
    // horizon's edge, where the integrand jumps, is placed as well as the emitters place it.
    thread_local std::vector<Eigen::Vector3d> l_local;
    l_local.clear();
    int first = -1, last = -1, lit = 0;
    for (int i = 0; i < static_cast<int>(o.emitters.size()); ++i) {
      const PointEmitter& e = o.emitters[i];
      l_local.push_back(frame.local_from_sample * (e.position_mm - p).normalized());
      if (!(e.IntensityTowards(p) > 0 && l_local.back().z() > 0) || hides(i)) continue;
      if (first < 0) first = i;
      last = i, ++lit;
    }
    if (first < 0) return false;  // fully shadowed
    const double count = static_cast<double>(o.emitters.size());
    const StripQuadratureOptions& quadrature = *options_.strip_quadrature;
    nodes = StripNodes(*strips_[k], {first / count, (last + 1) / count},
                       LobeSpan(l_local, observation.v_local, *lobe, quadrature.lobe_fraction), quadrature);
    nodes_lit = lit == last - first + 1;
  }
  if (directional_[k]) {
    // Lights at infinity (an imported capture's): one or a few, each its direction and irradiance.
    observation.lights.clear();
    for (int i = 0; i < static_cast<int>(o.emitters.size()); ++i) {
      const PointEmitter& e = o.emitters[i];
      const double irradiance = e.IrradianceAt(p);
      if (!(irradiance > 0) || hides(i)) continue;
      observation.lights.push_back({frame.local_from_sample * e.DirectionFrom(p), irradiance});
    }
    return !observation.lights.empty();
  }
  if (!integrate) {
    // The stack's emitters: their directions and irradiances all at once (fitting/model/internal/light_samples.h).
    thread_local internal::LightGeometry geometry;
    internal::LightGeometryAt(emitter_arrays_[k], p, frame.local_from_sample, geometry);
    const int count = emitter_arrays_[k].size();
    std::vector<LightSample>& lights = observation.lights;
    lights.resize(count);  // within the capacity the last pixel left: no allocation; then no push_back's checks
    int lit = 0;
    for (int i = 0; i < count; ++i) {
      if (!(geometry.irradiance[i] > 0) || hides(i)) continue;
      lights[lit++] = {{geometry.lx[i], geometry.ly[i], geometry.lz[i]}, geometry.irradiance[i]};
    }
    lights.resize(lit);
    return lit > 0;
  }
  // The strip's nodes, placed for this pixel: the direction to each is computed once (as
  // normalized() would) for its falloff and the pixel's frame.
  observation.lights.clear();
  for (const PointEmitter& node : nodes) {
    const Eigen::Vector3d to_light = node.position_mm - p;
    const double distance2 = to_light.squaredNorm();
    const Eigen::Vector3d l = to_light / std::sqrt(distance2);
    const double intensity = node.IntensityAlong(-l);
    if (intensity <= 0 || (!nodes_lit && shadowed(node))) continue;
    observation.lights.push_back({frame.local_from_sample.lazyProduct(l), intensity / distance2});
  }
  return !observation.lights.empty();
}

}  // namespace loom::fitting
