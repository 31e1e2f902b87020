#include "fitting/cnn/cnn_input.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <span>
#include <sstream>

#include <Eigen/Geometry>

#include "fitting/cnn/cnn.h"

namespace loom::fitting {

namespace {

// Turntable angles of one sweep agree within this (they come from one plan's steps).
constexpr double kSameTurntableDeg = 1e-3;

// One camera's linear-light observations at one turntable angle: stack indices by strip angle.
struct StackSweep {
  std::string camera;
  double turntable_deg = 0;
  std::vector<std::pair<double, int>> by_angle;  // (angle, observation index), ascending
};

// The sweep of `camera` at `turntable_deg` among `sweeps`, or their end.
std::vector<StackSweep>::const_iterator FindSweep(const std::vector<StackSweep>& sweeps, const std::string& camera,
                                                  double turntable_deg) {
  return std::find_if(sweeps.begin(), sweeps.end(), [&](const StackSweep& s) {
    return s.camera == camera && std::abs(s.turntable_deg - turntable_deg) < kSameTurntableDeg;
  });
}

std::vector<StackSweep> SweepsOf(const ObservationStack& stack) {
  std::vector<StackSweep> sweeps;
  for (int k = 0; k < static_cast<int>(stack.observations.size()); ++k) {
    const StackObservation& o = stack.observations[k];
    if (o.group != ObservationGroup::kLinearLight) continue;
    const size_t at = static_cast<size_t>(FindSweep(sweeps, o.camera, o.turntable_deg) - sweeps.cbegin());
    if (at == sweeps.size()) sweeps.push_back({o.camera, o.turntable_deg, {}});
    sweeps[at].by_angle.emplace_back(StripAngleDeg(o), k);
  }
  for (StackSweep& s : sweeps) std::sort(s.by_angle.begin(), s.by_angle.end());
  return sweeps;
}

std::string SweepName(const std::string& camera, double turntable_deg) {
  std::ostringstream name;
  name << "the linear-light sweep of " << camera << " at turntable " << turntable_deg << " deg";
  return name.str();
}

float LogRadiance(float value, float inverse_scale) {
  return std::isfinite(value) ? std::log1p(std::max(0.0f, value) * inverse_scale) : 0.0f;
}

// The mean over [lo, hi] of the piecewise-linear function through (x[i], y[i]) (x ascending),
// held constant beyond its ends.
double MeanOverInterval(const std::vector<double>& x, const std::vector<double>& y, double lo, double hi) {
  const size_t n = x.size();
  const auto value_at = [&](double t) {
    if (t <= x.front()) return y.front();
    if (t >= x.back()) return y.back();
    const size_t i = static_cast<size_t>(std::upper_bound(x.begin(), x.end(), t) - x.begin());
    return y[i - 1] + (y[i] - y[i - 1]) * (t - x[i - 1]) / (x[i] - x[i - 1]);
  };
  // Trapezoids between lo, the knots inside (lo, hi) and hi: exact for a piecewise-linear function.
  double integral = 0, t0 = lo, v0 = value_at(lo);
  for (size_t i = static_cast<size_t>(std::upper_bound(x.begin(), x.end(), lo) - x.begin()); i < n && x[i] < hi; ++i) {
    integral += (x[i] - t0) * (v0 + y[i]) / 2;
    t0 = x[i], v0 = y[i];
  }
  integral += (hi - t0) * (v0 + value_at(hi)) / 2;
  return integral / (hi - lo);
}

// Writes the input channels of `sweep` over each of `angles`' bins (from midway to the previous
// angle to midway to the next) to `out`, one plane after another: log radiance of the mean of
// the sweep's radiance, linear between its positions, over the bin; per pixel, unseen positions
// left out (0, unseen, where none is seen).
Status WriteResampled(const ObservationStack& stack, const StackSweep& sweep, const std::vector<double>& angles,
                      float inverse_scale, float* out) {
  const size_t n = angles.size();
  const auto bin_edge = [&](size_t j) {  // the edge between angle j − 1 and angle j
    if (j == 0) return angles[0] - (angles[1] - angles[0]) / 2;
    if (j == n) return angles[n - 1] + (angles[n - 1] - angles[n - 2]) / 2;
    return (angles[j - 1] + angles[j]) / 2;
  };
  // The sweep may stop short of the layout's outermost angles by up to a bin: no arm is where its
  // YAML puts it (a calibrated tac7 arm turned 1.5° sweeps −68.5° to 71.5°), and the shortfall is
  // held at the sweep's end value, as the half bin beyond the ends always is (docs/benchmarks.md
  // measures what that costs the CNN's maps). Further short, a whole bin would be invented.
  const double first = sweep.by_angle.front().first, last = sweep.by_angle.back().first;
  if (first > angles[1] || last < angles[n - 2]) {
    std::ostringstream message;
    message << SweepName(sweep.camera, sweep.turntable_deg) << " spans " << first << " to " << last << " deg, not the model's "
            << angles.front() << " to " << angles.back() << " deg";
    return FailedPreconditionError(stack.source, message.str());
  }
  std::vector<std::span<const float>> channels;
  for (const auto& [angle, k] : sweep.by_angle) channels.push_back(stack.image.channel(ObservationStack::ObservationChannel(k)));
  const size_t plane = stack.image.pixel_count();
  std::vector<double> x, y;
  for (size_t i = 0; i < plane; ++i) {
    x.clear(), y.clear();
    for (size_t s = 0; s < channels.size(); ++s) {
      if (std::isfinite(channels[s][i])) x.push_back(sweep.by_angle[s].first), y.push_back(channels[s][i]);
    }
    for (size_t j = 0; j < n; ++j) {
      const float mean = x.empty() ? NAN : static_cast<float>(MeanOverInterval(x, y, bin_edge(j), bin_edge(j + 1)));
      out[j * plane + i] = LogRadiance(mean, inverse_scale);
    }
  }
  return Status::Ok();
}

}  // namespace

int PaperInputLayout::Channels() const {
  int linear = 0;
  for (const PaperLinearSweep& s : sweeps) linear += static_cast<int>(s.angles_deg.size());
  return kCnnGeometryChannels + 3 * colour_observations + monochrome_observations + linear;
}

nlohmann::json PaperInputLayout::ToJson() const {
  nlohmann::json sweeps_json = nlohmann::json::array();
  for (const PaperLinearSweep& s : sweeps) {
    sweeps_json.push_back({{"camera", s.camera}, {"turntable_deg", s.turntable_deg}, {"angles_deg", s.angles_deg}});
  }
  return {{"colour_observations", colour_observations},
          {"monochrome_observations", monochrome_observations},
          {"linear_sweeps", sweeps_json}};
}

PaperInputLayout PaperInputLayout::FromJson(const nlohmann::json& json) {
  PaperInputLayout layout;
  layout.colour_observations = json.at("colour_observations").get<int>();
  layout.monochrome_observations = json.at("monochrome_observations").get<int>();
  for (const nlohmann::json& s : json.at("linear_sweeps")) {
    PaperLinearSweep sweep{s.at("camera").get<std::string>(), s.at("turntable_deg").get<double>(),
                           s.at("angles_deg").get<std::vector<double>>()};
    if (sweep.angles_deg.size() < 2 || !std::is_sorted(sweep.angles_deg.begin(), sweep.angles_deg.end())) {
      throw std::invalid_argument("linear_sweeps: " + sweep.camera + "'s angles_deg must be two or more, ascending");
    }
    layout.sweeps.push_back(std::move(sweep));
  }
  if (layout.colour_observations < 0 || layout.monochrome_observations < 0) {
    throw std::invalid_argument("colour_observations and monochrome_observations must be >= 0");
  }
  return layout;
}

double StripAngleDeg(const StackObservation& observation) {
  const std::vector<PointEmitter>& emitters = observation.emitters;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double weight = 0;
  for (const PointEmitter& e : emitters) centroid += e.intensity * e.position_mm, weight += e.intensity;
  if (weight > 0) centroid /= weight;
  // The strip's direction; a single emitter is taken as a strip along y (the sweep axis of the
  // rigs' YAML), in the sample frame at turntable 0.
  Eigen::Vector3d along = Eigen::Vector3d::UnitY();
  if (emitters.size() >= 2 && (emitters.back().position_mm - emitters.front().position_mm).norm() > 0) {
    along = (emitters.back().position_mm - emitters.front().position_mm).normalized();
  }
  const Eigen::Vector3d zenith = (Eigen::Vector3d::UnitZ() - along.z() * along).normalized();
  const Eigen::Vector3d side = along.cross(zenith);
  return std::atan2(centroid.dot(side), centroid.dot(zenith)) * 180 / std::numbers::pi;
}

Result<PaperInputLayout> PaperLayoutOf(const ObservationStack& stack) {
  PaperInputLayout layout;
  for (const StackObservation& o : stack.observations) {
    layout.colour_observations += o.group == ObservationGroup::kColour;
    layout.monochrome_observations += o.group == ObservationGroup::kMonochrome;
  }
  for (const StackSweep& s : SweepsOf(stack)) {
    PaperLinearSweep sweep{s.camera, s.turntable_deg, {}};
    for (const auto& [angle, k] : s.by_angle) sweep.angles_deg.push_back(angle);
    const bool distinct = std::adjacent_find(sweep.angles_deg.begin(), sweep.angles_deg.end()) == sweep.angles_deg.end();
    if (sweep.angles_deg.size() < 2 || !distinct) {
      return FailedPreconditionError(stack.source, SweepName(s.camera, s.turntable_deg) +
                                                       " needs two or more distinct strip positions for the paper layout");
    }
    layout.sweeps.push_back(std::move(sweep));
  }
  if (layout.colour_observations == 0 || layout.monochrome_observations == 0 || layout.sweeps.empty()) {
    return FailedPreconditionError(
        stack.source, "the paper layout needs colour, monochrome and linear-light observations; this stack has " +
                          std::to_string(layout.colour_observations) + ", " + std::to_string(layout.monochrome_observations) +
                          " and " + std::to_string(layout.sweeps.size()) + " sweeps");
  }
  return layout;
}

namespace {

// Height above the stack's median and the geometric normal: the first kCnnGeometryChannels.
void GeometryChannels(const ObservationStack& stack, CnnTensor& input) {
  const size_t plane = stack.image.pixel_count();
  std::vector<float> heights(stack.image.channel(2).begin(), stack.image.channel(2).end());
  std::nth_element(heights.begin(), heights.begin() + plane / 2, heights.end());
  const float median_height = heights[plane / 2];
  for (size_t i = 0; i < plane; ++i) input.values[i] = stack.image.channel(2)[i] - median_height;
  for (int c = 0; c < 3; ++c) {
    std::copy(stack.image.channel(3 + c).begin(), stack.image.channel(3 + c).end(), input.values.begin() + (1 + c) * plane);
  }
}

CnnTensor EmptyInput(const ObservationStack& stack, int channels) {
  CnnTensor input{channels, stack.image.height(), stack.image.width(), {}};
  input.values.resize(stack.image.pixel_count() * channels);
  GeometryChannels(stack, input);
  return input;
}

}  // namespace

Result<CnnTensor> PaperInputFromStack(const ObservationStack& stack, const PaperInputLayout& layout, double radiance_scale) {
  std::vector<int> colour, monochrome;
  for (int k = 0; k < static_cast<int>(stack.observations.size()); ++k) {
    if (stack.observations[k].group == ObservationGroup::kColour) colour.push_back(k);
    if (stack.observations[k].group == ObservationGroup::kMonochrome) monochrome.push_back(k);
  }
  if (static_cast<int>(colour.size()) != layout.colour_observations ||
      static_cast<int>(monochrome.size()) != layout.monochrome_observations) {
    return FailedPreconditionError(
        stack.source, "its " + std::to_string(colour.size()) + " colour and " + std::to_string(monochrome.size()) +
                          " monochrome observations are not the model's " + std::to_string(layout.colour_observations) + " and " +
                          std::to_string(layout.monochrome_observations));
  }
  const std::vector<StackSweep> sweeps = SweepsOf(stack);
  CnnTensor input = EmptyInput(stack, layout.Channels());
  const size_t plane = stack.image.pixel_count();
  const float inverse_scale = static_cast<float>(1 / radiance_scale);
  float* out = input.values.data() + kCnnGeometryChannels * plane;
  for (int k : colour) {
    const Eigen::Vector3d& w = stack.observations[k].rgb_weights;
    const auto values = stack.image.channel(ObservationStack::ObservationChannel(k));
    for (int c = 0; c < 3; ++c, out += plane) {
      const float to_rgb = static_cast<float>(w[c] / std::max(w.squaredNorm(), 1e-12));
      for (size_t i = 0; i < plane; ++i) out[i] = LogRadiance(values[i] * to_rgb, inverse_scale);
    }
  }
  for (int k : monochrome) {
    const auto values = stack.image.channel(ObservationStack::ObservationChannel(k));
    for (size_t i = 0; i < plane; ++i) out[i] = LogRadiance(values[i], inverse_scale);
    out += plane;
  }
  for (const PaperLinearSweep& wanted : layout.sweeps) {
    const auto sweep = FindSweep(sweeps, wanted.camera, wanted.turntable_deg);
    if (sweep == sweeps.end()) {
      return FailedPreconditionError(stack.source,
                                     "has no " + SweepName(wanted.camera, wanted.turntable_deg) + ", which the model takes");
    }
    LOOM_RETURN_IF_ERROR(WriteResampled(stack, *sweep, wanted.angles_deg, inverse_scale, out));
    out += wanted.angles_deg.size() * plane;
  }
  return input;
}

Result<CnnTensor> CnnInputFromStack(const ObservationStack& stack, const CnnModelInfo& info) {
  if (info.paper_layout) {
    if (!info.rig.empty() && stack.rig != info.rig) {
      return FailedPreconditionError(stack.source, "a stack of rig '" + stack.rig + "', the model is for rig '" + info.rig + "'");
    }
    if (info.architecture.input_channels != info.paper_layout->Channels()) {
      return FailedPreconditionError(stack.source,
                                     "the model's paper layout has " + std::to_string(info.paper_layout->Channels()) +
                                         " channels, its architecture " + std::to_string(info.architecture.input_channels));
    }
    return PaperInputFromStack(stack, *info.paper_layout, info.radiance_scale);
  }
  const int n = static_cast<int>(stack.observations.size());
  bool same_layout = n == static_cast<int>(info.observation_groups.size());
  for (int k = 0; same_layout && k < n; ++k) same_layout = stack.observations[k].group == info.observation_groups[k];
  if (!same_layout || info.architecture.input_channels != kCnnGeometryChannels + n) {
    return FailedPreconditionError(
        stack.source, "its " + std::to_string(n) + " observations are not the layout the model was trained on (" +
                          std::to_string(info.observation_groups.size()) + " observations of rig '" + info.rig + "')");
  }
  CnnTensor input = EmptyInput(stack, kCnnGeometryChannels + n);
  const size_t plane = stack.image.pixel_count();
  const float inverse_scale = static_cast<float>(1 / info.radiance_scale);
  for (int k = 0; k < n; ++k) {
    const auto values = stack.image.channel(ObservationStack::ObservationChannel(k));
    float* out = input.values.data() + (kCnnGeometryChannels + k) * plane;
    for (size_t i = 0; i < plane; ++i) out[i] = LogRadiance(values[i], inverse_scale);
  }
  return input;
}

}  // namespace loom::fitting
