#include "fitting/cnn/torch/rerender_loss.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "fitting/cnn/torch/label_loss.h"
#include "fitting/model/strip_quadrature.h"
#include "fitting/model/ward_gd10.h"

namespace loom::fitting::internal {
namespace {

constexpr double kMinNormalZ = 1e-3;            // DecodeLabel's
constexpr double kNegligibleLobeExponent = 60;  // the fitters' (fitting/solve/pixel_cost.cc)

// The batch in float, as the rendering is: a training loss needs no more, and float halves the
// memory and doubles the vector width (training at 1/8 width on one core: about 44,000 →
// 55,000 samples/s against double).
at::Tensor Floats(const std::vector<double>& values, int64_t columns) {
  const int64_t rows = static_cast<int64_t>(values.size()) / columns;
  at::Tensor t = at::empty({rows, columns}, at::kFloat);
  std::transform(values.begin(), values.end(), t.data_ptr<float>(), [](double v) { return static_cast<float>(v); });
  return columns == 1 ? t.view({rows}) : t;
}

at::Tensor Indices(const std::vector<int64_t>& values) {
  at::Tensor t = at::empty({static_cast<int64_t>(values.size())}, at::kLong);
  std::copy(values.begin(), values.end(), t.data_ptr<int64_t>());
  return t;
}

at::Tensor Dot(const at::Tensor& a, const at::Tensor& b) { return (a * b).sum(1); }

at::Tensor Normalized(const at::Tensor& a) { return a / a.norm(2, 1, true); }

}  // namespace

std::vector<int64_t> DrawPixels(const at::Tensor& weights, int count, std::mt19937_64& rng) {
  const at::Tensor w = weights.to(at::kCPU, at::kDouble).contiguous().flatten();
  if (w.numel() == 0 || !(w.sum().item<double>() > 0)) return {};
  const double* begin = w.data_ptr<double>();
  std::discrete_distribution<int64_t> pick(begin, begin + w.numel());
  std::vector<int64_t> drawn(static_cast<size_t>(count));
  for (int64_t& pixel : drawn) pixel = pick(rng);
  return drawn;
}

RerenderBatch MakeRerenderBatch(const std::vector<std::vector<PixelObservation>>& pixels, int max_lights) {
  std::vector<double> l, irradiance, v, weights, radiance, inverse_scale;
  std::vector<int64_t> sample_observation, observation_pixel;
  int64_t observation = 0;
  for (size_t p = 0; p < pixels.size(); ++p) {
    double sum = 0;
    int used = 0;
    for (const PixelObservation& o : pixels[p]) {
      if (!std::isfinite(o.radiance) || o.lights.empty()) continue;
      std::vector<LightSample> lights;
      for (const LightSample& light : o.lights) {
        if (o.v_local.z() > 0 && light.l_local.z() > 0 && (light.l_local + o.v_local).squaredNorm() >= 1e-20) {
          lights.push_back(light);
        }
      }
      if (max_lights > 0) lights = MergeLightSamples(lights, max_lights);
      for (const LightSample& light : lights) {
        l.insert(l.end(), {light.l_local.x(), light.l_local.y(), light.l_local.z()});
        irradiance.push_back(light.irradiance);
        sample_observation.push_back(observation);
      }
      v.insert(v.end(), {o.v_local.x(), o.v_local.y(), o.v_local.z()});
      weights.insert(weights.end(), {o.rgb_weights.x(), o.rgb_weights.y(), o.rgb_weights.z()});
      radiance.push_back(o.radiance);
      observation_pixel.push_back(static_cast<int64_t>(p));
      sum += std::abs(o.radiance);
      ++used;
      ++observation;
    }
    const double mean = used > 0 ? sum / used : 0;
    inverse_scale.push_back(mean > 0 ? 1 / mean : 1);
  }
  RerenderBatch batch;
  batch.l = Floats(l, 3);
  batch.irradiance = Floats(irradiance, 1);
  batch.sample_observation = Indices(sample_observation);
  batch.v = Floats(v, 3);
  batch.weights = Floats(weights, 3);
  batch.radiance = Floats(radiance, 1);
  batch.observation_pixel = Indices(observation_pixel);
  batch.inverse_scale = Floats(inverse_scale, 1);
  batch.pixels = static_cast<int64_t>(pixels.size());
  return batch;
}

at::Tensor ToDevice(const at::Tensor& host, const at::Device& device) {
  if (!device.is_cuda()) return host.to(device);
  return host.pin_memory().to(device, /*non_blocking=*/true);
}

RerenderBatch RerenderBatch::To(const at::Device& device) const {
  return {ToDevice(l, device),
          ToDevice(irradiance, device),
          ToDevice(sample_observation, device),
          ToDevice(v, device),
          ToDevice(weights, device),
          ToDevice(radiance, device),
          ToDevice(observation_pixel, device),
          ToDevice(inverse_scale, device),
          pixels};
}

at::Tensor RenderObservations(const at::Tensor& labels, const RerenderBatch& batch) {
  const at::Tensor x = labels.to(at::kFloat);
  // DecodeLabel, per pixel, but for the albedos' clamp at 0: the radiance is linear in them, and
  // a negative one renders a negative radiance whose residual pushes it back (a clamp would
  // leave it there, with no gradient).
  const at::Tensor a_d = x.narrow(1, 0, 3);
  const at::Tensor a_s = x.narrow(1, 3, 3);
  const at::Tensor n = Normalized(at::cat({x.narrow(1, 6, 2), at::clamp_min(x.narrow(1, 8, 1), kMinNormalZ)}, 1));
  const at::Tensor sigma_x = DecodeSigma(x.select(1, 9)), sigma_y = DecodeSigma(x.select(1, 10));
  const at::Tensor alpha = 0.5 * at::atan2(x.select(1, 12), x.select(1, 11));
  const at::Tensor f0 = at::clamp(x.select(1, 13), 0.0, 1.0);
  // The anisotropy frame: t = normalize(t0 − (t0·n) n), b = n × t.
  const at::Tensor t0 = at::stack({at::cos(alpha), at::sin(alpha), at::zeros_like(alpha)}, 1);
  const at::Tensor t = Normalized(t0 - Dot(t0, n).unsqueeze(1) * n);
  const at::Tensor b = at::cross(n, t, 1);

  // Per observation, then per sample.
  const at::Tensor& pixel = batch.observation_pixel;
  const at::Tensor diffuse_albedo = Dot(batch.weights, a_d.index_select(0, pixel));
  const at::Tensor specular_albedo = Dot(batch.weights, a_s.index_select(0, pixel));
  const at::Tensor& o = batch.sample_observation;
  const at::Tensor sample_pixel = pixel.index_select(0, o);
  const at::Tensor ns = n.index_select(0, sample_pixel), ts = t.index_select(0, sample_pixel),
                   bs = b.index_select(0, sample_pixel);
  const at::Tensor v = batch.v.index_select(0, o);
  const at::Tensor& l = batch.l;
  const at::Tensor n_dot_l = Dot(ns, l), n_dot_v = Dot(ns, v);
  const at::Tensor lit = (n_dot_l > 0).logical_and(n_dot_v > 0).to(at::kFloat);
  const at::Tensor h = Normalized(l + v);
  const at::Tensor h_t = Dot(h, ts), h_b = Dot(h, bs), h_n = at::clamp_min(Dot(h, ns), 1e-3);
  const at::Tensor c = at::clamp(Dot(l, h), 1e-3, 1.0);
  const at::Tensor exponent = (h_t.square() / sigma_x.index_select(0, sample_pixel).square() +
                               h_b.square() / sigma_y.index_select(0, sample_pixel).square()) /
                              h_n.square();
  const at::Tensor kept = (exponent <= kNegligibleLobeExponent).to(at::kFloat);
  const at::Tensor ward = kept * at::exp(-at::clamp_max(exponent, kNegligibleLobeExponent)) /
                          (4 * kPi * sigma_x.index_select(0, sample_pixel) * sigma_y.index_select(0, sample_pixel) * c.square() *
                           h_n.square().square());
  const at::Tensor f0s = f0.index_select(0, sample_pixel);
  const at::Tensor fresnel = f0s + (1 - f0s) * at::pow(1 - c, 5);
  const at::Tensor shading = diffuse_albedo.index_select(0, o) / kPi + specular_albedo.index_select(0, o) * fresnel * ward;
  const at::Tensor sample_radiance = lit * batch.irradiance * shading * at::clamp_min(n_dot_l, 0.0);
  return at::zeros({batch.v.size(0)}, batch.v.options()).index_add(0, o, sample_radiance);
}

at::Tensor RerenderLoss(const at::Tensor& labels, const RerenderBatch& batch, double huber_delta) {
  const at::Tensor scale = batch.inverse_scale.index_select(0, batch.observation_pixel);
  const at::Tensor residual = (RenderObservations(labels, batch) - batch.radiance) * scale;
  return at::huber_loss(residual, at::zeros_like(residual), at::Reduction::Mean, huber_delta);
}

}  // namespace loom::fitting::internal
