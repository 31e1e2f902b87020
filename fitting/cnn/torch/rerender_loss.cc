#include "fitting/cnn/torch/rerender_loss.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

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

// The light samples an observation renders with (those above both horizons, merged into at most
// `max_lights`), or nothing when it is not usable (unseen, or lit by nothing).
std::optional<std::vector<LightSample>> RenderedLights(const PixelObservation& o, int max_lights) {
  if (!std::isfinite(o.radiance) || o.lights.empty()) return std::nullopt;
  std::vector<LightSample> lights;
  for (const LightSample& light : o.lights) {
    if (o.v_local.z() > 0 && light.l_local.z() > 0 && (light.l_local + o.v_local).squaredNorm() >= 1e-20) {
      lights.push_back(light);
    }
  }
  if (max_lights > 0) lights = MergeLightSamples(lights, max_lights);
  return lights;
}

// A table of `rows` rows of nothing but padding, `observations` × `samples` wide.
RerenderTable PaddingTable(int64_t rows, int64_t observations, int64_t samples, const at::TensorOptions& options) {
  RerenderTable t;
  t.l = at::zeros({rows, samples, 3}, options);
  t.l.select(2, 2).fill_(1);
  t.irradiance = at::zeros({rows, samples}, options);
  t.sample_observation = at::zeros({rows, samples}, options.dtype(at::kInt));
  t.v = at::zeros({rows, observations, 3}, options);
  t.v.select(2, 2).fill_(1);
  t.weights = at::zeros({rows, observations, 3}, options);
  t.radiance = at::zeros({rows, observations}, options);
  t.observation_weight = at::zeros({rows, observations}, options);
  t.inverse_scale = at::ones({rows}, options);
  return t;
}

// `table` padded to `observations` × `samples` per row.
RerenderTable PaddedTable(const RerenderTable& table, int64_t observations, int64_t samples) {
  const int64_t o = table.v.size(1), s = table.l.size(1);
  if (o == observations && s == samples) return table;
  RerenderTable t = PaddingTable(table.rows(), observations, samples, table.l.options());
  t.l.narrow(1, 0, s).copy_(table.l);
  t.irradiance.narrow(1, 0, s).copy_(table.irradiance);
  t.sample_observation.narrow(1, 0, s).copy_(table.sample_observation);
  t.v.narrow(1, 0, o).copy_(table.v);
  t.weights.narrow(1, 0, o).copy_(table.weights);
  t.radiance.narrow(1, 0, o).copy_(table.radiance);
  t.observation_weight.narrow(1, 0, o).copy_(table.observation_weight);
  t.inverse_scale.copy_(table.inverse_scale);
  return t;
}

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

at::Tensor DrawRows(const at::Tensor& weights, int count, std::mt19937_64& rng) {
  std::vector<float> uniform(static_cast<size_t>(weights.size(0)) * static_cast<size_t>(count));
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (float& u : uniform) u = unit(rng);
  const at::Tensor none = (weights.sum(1, /*keepdim=*/true) <= 0).to(weights.dtype());
  const at::Tensor cdf = (weights + none).cumsum(1);
  const at::Tensor u = ToDevice(at::tensor(uniform).view({weights.size(0), count}), weights.device());
  const at::Tensor target = u * cdf.narrow(1, cdf.size(1) - 1, 1);
  return at::clamp_max(at::searchsorted(cdf, target, /*out_int32=*/false, /*right=*/true), weights.size(1) - 1);
}

RerenderBatch MakeRerenderBatch(const std::vector<std::vector<PixelObservation>>& pixels, int max_lights) {
  std::vector<double> l, irradiance, v, weights, radiance, inverse_scale;
  std::vector<int64_t> sample_observation, observation_pixel;
  int64_t observation = 0;
  for (size_t p = 0; p < pixels.size(); ++p) {
    double sum = 0;
    int used = 0;
    for (const PixelObservation& o : pixels[p]) {
      const std::optional<std::vector<LightSample>> lights = RenderedLights(o, max_lights);
      if (!lights) continue;
      for (const LightSample& light : *lights) {
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

RerenderTable MakeRerenderTable(const std::vector<std::vector<PixelObservation>>& pixels, int max_lights) {
  int64_t observations = 0, samples = 0;
  // Each row's usable observations with their samples first, for the padded width.
  std::vector<std::vector<std::pair<const PixelObservation*, std::vector<LightSample>>>> rows(pixels.size());
  for (size_t p = 0; p < pixels.size(); ++p) {
    int64_t row_samples = 0;
    for (const PixelObservation& o : pixels[p]) {
      std::optional<std::vector<LightSample>> lights = RenderedLights(o, max_lights);
      if (!lights) continue;
      row_samples += static_cast<int64_t>(lights->size());
      rows[p].emplace_back(&o, std::move(*lights));
    }
    observations = std::max(observations, static_cast<int64_t>(rows[p].size()));
    samples = std::max(samples, row_samples);
  }
  RerenderTable t = PaddingTable(static_cast<int64_t>(pixels.size()), observations, samples, at::TensorOptions(at::kFloat));
  auto l = t.l.accessor<float, 3>(), v = t.v.accessor<float, 3>(), w = t.weights.accessor<float, 3>();
  auto irradiance = t.irradiance.accessor<float, 2>(), radiance = t.radiance.accessor<float, 2>();
  auto weight = t.observation_weight.accessor<float, 2>();
  auto sample_observation = t.sample_observation.accessor<int32_t, 2>();
  auto inverse_scale = t.inverse_scale.accessor<float, 1>();
  for (size_t p = 0; p < rows.size(); ++p) {
    double sum = 0;
    int64_t s = 0;
    for (size_t k = 0; k < rows[p].size(); ++k) {
      const auto& [o, lights] = rows[p][k];
      for (int c = 0; c < 3; ++c)
        v[p][k][c] = static_cast<float>(o->v_local[c]), w[p][k][c] = static_cast<float>(o->rgb_weights[c]);
      radiance[p][k] = static_cast<float>(o->radiance);
      weight[p][k] = 1;
      sum += std::abs(o->radiance);
      for (const LightSample& light : lights) {
        for (int c = 0; c < 3; ++c) l[p][s][c] = static_cast<float>(light.l_local[c]);
        irradiance[p][s] = static_cast<float>(light.irradiance);
        sample_observation[p][s++] = static_cast<int32_t>(k);
      }
    }
    const double mean = rows[p].empty() ? 0 : sum / static_cast<double>(rows[p].size());
    inverse_scale[p] = static_cast<float>(mean > 0 ? 1 / mean : 1);
  }
  return t;
}

RerenderTable ConcatRerenderTables(const std::vector<RerenderTable>& tables) {
  int64_t observations = 0, samples = 0;
  for (const RerenderTable& t : tables) {
    observations = std::max(observations, t.v.size(1));
    samples = std::max(samples, t.l.size(1));
  }
  std::vector<RerenderTable> padded;
  for (const RerenderTable& t : tables) padded.push_back(PaddedTable(t, observations, samples));
  const auto cat = [&padded](at::Tensor RerenderTable::*field) {
    std::vector<at::Tensor> parts;
    for (const RerenderTable& t : padded) parts.push_back(t.*field);
    return at::cat(parts);
  };
  return {cat(&RerenderTable::l),
          cat(&RerenderTable::irradiance),
          cat(&RerenderTable::sample_observation),
          cat(&RerenderTable::v),
          cat(&RerenderTable::weights),
          cat(&RerenderTable::radiance),
          cat(&RerenderTable::observation_weight),
          cat(&RerenderTable::inverse_scale)};
}

RerenderTable RerenderTable::To(const at::Device& device) const {
  return {ToDevice(l, device),
          ToDevice(irradiance, device),
          ToDevice(sample_observation, device),
          ToDevice(v, device),
          ToDevice(weights, device),
          ToDevice(radiance, device),
          ToDevice(observation_weight, device),
          ToDevice(inverse_scale, device)};
}

RerenderBatch GatherRerenderBatch(const RerenderTable& table, const at::Tensor& rows, const at::Tensor& pixel_weight) {
  const int64_t pixels = rows.size(0), observations = table.v.size(1), samples = table.l.size(1);
  const at::Tensor first_observation = at::arange(pixels, rows.options()).mul_(observations).unsqueeze(1);
  RerenderBatch batch;
  batch.l = table.l.index_select(0, rows).reshape({pixels * samples, 3});
  batch.irradiance = table.irradiance.index_select(0, rows).reshape({pixels * samples});
  batch.sample_observation =
      (table.sample_observation.index_select(0, rows).to(at::kLong) + first_observation).reshape({pixels * samples});
  batch.v = table.v.index_select(0, rows).reshape({pixels * observations, 3});
  batch.weights = table.weights.index_select(0, rows).reshape({pixels * observations, 3});
  batch.radiance = table.radiance.index_select(0, rows).reshape({pixels * observations});
  batch.observation_pixel = at::arange(pixels, rows.options()).repeat_interleave(observations);
  batch.inverse_scale = table.inverse_scale.index_select(0, rows);
  batch.observation_weight = (table.observation_weight.index_select(0, rows) * pixel_weight.to(at::kFloat).unsqueeze(1))
                                 .reshape({pixels * observations});
  batch.pixels = pixels;
  return batch;
}

at::Tensor ToDevice(const at::Tensor& host, const at::Device& device) {
  if (!device.is_cuda()) return host.to(device);
  return host.pin_memory().to(device, /*non_blocking=*/true);
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
  if (!batch.observation_weight.defined()) {
    return at::huber_loss(residual, at::zeros_like(residual), at::Reduction::Mean, huber_delta);
  }
  const at::Tensor each = at::huber_loss(residual, at::zeros_like(residual), at::Reduction::None, huber_delta);
  // No sum of weights read back: a step that waited for it would wait for the device.
  return (each * batch.observation_weight).sum() / at::clamp_min(batch.observation_weight.sum(), 1.0);
}

}  // namespace loom::fitting::internal
