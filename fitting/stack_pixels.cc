#include "fitting/stack_pixels.h"

#include <cmath>

#include "core/geometry.h"

namespace loom::fitting {

StackPixels::StackPixels(const ObservationStack& stack, const StackPixelOptions& options) : stack_(stack), options_(options) {
  const auto heights = stack.image.channel(2);  // pos.Z
  heightmap_ =
      Heightmap(std::vector<float>(heights.begin(), heights.end()), stack.image.width(), stack.image.height(), stack.pixel_mm);
}

Eigen::Matrix3d StackPixels::LocalFromSample(int x, int y) const {
  return WorldFromLocal(stack_.Normal(x, y), Eigen::Vector3d::UnitX()).transpose();
}

StackPixels::PixelFrame StackPixels::FrameOf(int x, int y) const {
  const Eigen::Vector3d position = stack_.Position(x, y);
  const double clearing_slope = options_.cast_shadows ? heightmap_.ClearingSlope(position) : 0.0;
  return {position, LocalFromSample(x, y), clearing_slope};
}

std::vector<PixelObservation> StackPixels::Observations(int x, int y) const {
  std::vector<PixelObservation> observations;
  observations.reserve(stack_.observations.size());
  const PixelFrame frame = FrameOf(x, y);
  for (size_t k = 0; k < stack_.observations.size(); ++k) Observe(static_cast<int>(k), x, y, frame, observations);
  return observations;
}

std::vector<PixelObservation> StackPixels::Observations(int x, int y, std::span<const int> only) const {
  std::vector<PixelObservation> observations;
  const PixelFrame frame = FrameOf(x, y);
  for (int k : only) Observe(k, x, y, frame, observations);
  return observations;
}

void StackPixels::Observe(int k, int x, int y, const PixelFrame& frame, std::vector<PixelObservation>& out) const {
  const float radiance = stack_.image.at(ObservationStack::ObservationChannel(k), y, x);
  if (std::isnan(radiance)) return;
  const StackObservation& o = stack_.observations[k];
  const Eigen::Vector3d& p = frame.position;
  PixelObservation observation;
  observation.radiance = radiance;
  observation.v_local = frame.local_from_sample * (o.camera_mm - p).normalized();
  observation.rgb_weights = o.rgb_weights;
  observation.source = k;
  for (const PointEmitter& emitter : o.emitters) {
    const double intensity = emitter.IntensityTowards(p);
    if (intensity <= 0) continue;
    if (options_.cast_shadows && heightmap_.Shadowed(p, emitter.position_mm, frame.clearing_slope)) continue;
    const Eigen::Vector3d to_light = emitter.position_mm - p;
    observation.lights.push_back({frame.local_from_sample * to_light.normalized(), intensity / to_light.squaredNorm()});
  }
  if (!observation.lights.empty()) out.push_back(std::move(observation));
}

}  // namespace loom::fitting
