#include "fitting/solve/internal/refine_lanes.h"

#include <algorithm>
#include <cmath>

#include "core/check.h"
#include "fitting/solve/batch_refiner.h"

namespace loom::fitting::internal {

UsableObservations Usable(const std::vector<PixelObservation>& all) {
  UsableObservations usable;
  for (size_t k = 0; k < all.size(); ++k) {
    const PixelObservation& o = all[k];
    if (std::isnan(o.radiance) || o.lights.empty()) continue;
    usable.observations.push_back(&o);
    usable.slots.push_back(o.source >= 0 ? o.source : static_cast<int>(k));
  }
  return usable;
}

namespace {

// Whether the model can light an observation seen along `v` (above its geometric horizon: the
// caller checks that once per observation) by `light` at all, whatever the parameters: l above
// the horizon and l + v not ≈ 0. The Ceres cost drops the same ones.
[[gnu::always_inline]] inline bool Counts(const LightSample& light, const Eigen::Vector3d& v) {
  return light.l_local.z() > 0 && (light.l_local + v).squaredNorm() >= 1e-20;
}

// Stores `light`'s halfway vector (l + v normalised) and irradiance in `slot` of `lane` where it
// Counts. True where stored.
[[gnu::always_inline]] inline bool StoreLight(const LightSample& light, const Eigen::Vector3d& v, int slot, int lane,
                                              LaneData& data) {
  if (!Counts(light, v)) return false;
  const Eigen::Vector3d sum = light.l_local + v;
  const Eigen::Vector3d h = sum * (1 / std::sqrt(sum.squaredNorm()));  // one division, not normalized()'s three
  const size_t s = static_cast<size_t>(slot) * kLanes + lane;
  data.hx[s] = h.x(), data.hy[s] = h.y(), data.hz[s] = h.z();
  data.irradiance[s] = light.irradiance;
  return true;
}

}  // namespace

double LoadLane(const UsableObservations& usable, int lane, LaneData& data) {
  data.ClearLane(lane);
  double sum = 0;
  thread_local std::vector<LightSample> lights;  // reused: one allocation per thread, not per observation
  for (size_t u = 0; u < usable.observations.size(); ++u) {
    const PixelObservation& o = *usable.observations[u];
    const int slot = usable.slots[u];
    LOOM_CHECK(slot >= 0 && slot < data.observations)
        << "observation slot " << slot << " outside the batch's " << data.observations;
    const size_t i = static_cast<size_t>(slot) * kLanes + lane;
    data.radiance[i] = o.radiance;
    data.weight[i] = 1;
    data.vx[i] = o.v_local.x(), data.vy[i] = o.v_local.y(), data.vz[i] = o.v_local.z();
    data.wr[i] = o.rgb_weights.x(), data.wg[i] = o.rgb_weights.y(), data.wb[i] = o.rgb_weights.z();
    sum += std::abs(o.radiance);
    // More lights than the slot holds (a strip's emitters) are merged along the strip; where they
    // fit, each goes straight to its slot.
    const int first = data.first_slot[slot];
    const int capacity = data.first_slot[slot + 1] - first;
    if (!(o.v_local.z() > 0)) continue;  // seen from below its horizon: no light counts
    int light_slot = first;
    if (static_cast<int>(o.lights.size()) <= capacity) {
      for (const LightSample& light : o.lights) light_slot += StoreLight(light, o.v_local, light_slot, lane, data);
      continue;
    }
    lights.clear();
    for (const LightSample& light : o.lights) {
      if (Counts(light, o.v_local)) lights.push_back(light);
    }
    if (static_cast<int>(lights.size()) > capacity) lights = MergeLightSamples(lights, capacity);
    for (const LightSample& light : lights) light_slot += StoreLight(light, o.v_local, light_slot, lane, data);
  }
  const double mean = sum / usable.observations.size();
  return mean > 0 ? 1 / mean : 1;
}

}  // namespace loom::fitting::internal
