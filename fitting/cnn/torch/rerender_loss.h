#pragma once
// The CNN's re-rendering loss (issue #22; the paper names it as future work): the GD10 model in
// torch ops, so that a network's predicted labels are rendered under a pixel's own observations
// (lights, view, colour weights) and compared with what was observed, with gradients back to
// the labels. Included by fitting/cnn/torch/cnn_trainer.cc and its test only (ATen, not all of torch).
//
// The model is fitting/solve/pixel_fitter.h's PredictRadiance of DecodeLabel(label) (fitting/model/label.h):
// the same clamps (σ ≥ kSigmaFloor, F0 ∈ [0, 1], n_s renormalised with n_z > 0) but for the
// albedos' (a negative albedo renders negatively, so that its gradient pushes it back), the lobe
// dropped beyond exponent 60 as the fitters drop it. Computed in float.

#include <cstdint>
#include <random>
#include <vector>

#include <ATen/ATen.h>

#include "fitting/model/observation.h"

namespace loom::fitting::internal {

// Observations of P pixels flattened: S light samples, O observations.
struct RerenderBatch {
  at::Tensor l;                   // S × 3, towards the light, local frame
  at::Tensor irradiance;          // S
  at::Tensor sample_observation;  // S, int64: the observation each sample lights
  at::Tensor v, weights;          // O × 3: towards the camera, colour weights
  at::Tensor radiance;            // O: observed
  at::Tensor observation_pixel;   // O, int64
  at::Tensor inverse_scale;       // P: 1 / the pixel's mean observed radiance (1 if 0)
  // O: what each observation weighs in the loss's mean (0: padding of a gathered batch);
  // undefined: 1 each.
  at::Tensor observation_weight;
  int64_t pixels = 0;
};

// `host` (a CPU tensor) on `device`. To a GPU through pinned memory and without waiting: a plain
// copy from pageable memory waits for everything queued before it, so a training step would wait
// for the one before.
at::Tensor ToDevice(const at::Tensor& host, const at::Device& device);

// `count` flat indices into a tile's pixels, drawn with replacement with probability ∝ `weights`
// (the tile's H × W, ≥ 0, 0 where a pixel is not valid): the pixels the re-rendering loss
// renders. None when every weight is 0.
std::vector<int64_t> DrawPixels(const at::Tensor& weights, int count, std::mt19937_64& rng);

// `count` draws from each row of `weights` (N × K, ≥ 0, on any device): column indices (N × count,
// int64, on that device) with probability ∝ the row's weights, by inverse CDF from uniform numbers
// that `rng` draws on the host, so that every device draws the same; a row of zeros draws
// uniformly. Nothing is read back from the device.
at::Tensor DrawRows(const at::Tensor& weights, int count, std::mt19937_64& rng);

// Each pixel's usable observations (finite radiance, a light, camera and light above the
// geometric horizon), a strip's emitters merged into at most `max_lights` samples (0: all;
// MergeLightSamples).
RerenderBatch MakeRerenderBatch(const std::vector<std::vector<PixelObservation>>& pixels, int max_lights);

// Every pixel of a material with its usable observations as MakeRerenderBatch selects and merges
// them, padded to the same number of observations O and light samples S per pixel, so that a
// training step gathers its drawn pixels' batch by row, where the network trains, with nothing
// done per pixel on the host. Padding renders nothing: an observation of weight 0, lit by samples
// of irradiance 0 (towards +z, so that the rendering stays finite).
struct RerenderTable {
  at::Tensor l;                   // rows × S × 3
  at::Tensor irradiance;          // rows × S
  at::Tensor sample_observation;  // rows × S, int32: the observation within its row
  at::Tensor v, weights;          // rows × O × 3
  at::Tensor radiance;            // rows × O
  at::Tensor observation_weight;  // rows × O: 1, or 0 for padding
  at::Tensor inverse_scale;       // rows

  int64_t rows() const { return inverse_scale.defined() ? inverse_scale.size(0) : 0; }
  RerenderTable To(const at::Device& device) const;
};

// The table of `pixels` (one row each, in order), as wide as its widest row.
RerenderTable MakeRerenderTable(const std::vector<std::vector<PixelObservation>>& pixels, int max_lights);

// The tables one after another (rows of the first, then of the second, ...), each padded to the
// widest.
RerenderTable ConcatRerenderTables(const std::vector<RerenderTable>& tables);

// The batch of the table's rows `rows` (B, int64, on the table's device): pixel b of the batch is
// row rows[b], its observations weighed by `pixel_weight`[b] (B; 0 leaves the pixel out).
RerenderBatch GatherRerenderBatch(const RerenderTable& table, const at::Tensor& rows, const at::Tensor& pixel_weight);

// The radiance of every observation of the batch under its pixel's label (P × 14, any float
// type): O values, float.
at::Tensor RenderObservations(const at::Tensor& labels, const RerenderBatch& batch);

// Mean over the observations (weighed by observation_weight, when the batch has it; 0 when they
// weigh nothing) of Huber(δ = huber_delta) of (rendered − observed) · inverse_scale, the
// residual the fitters minimise.
at::Tensor RerenderLoss(const at::Tensor& labels, const RerenderBatch& batch, double huber_delta);

}  // namespace loom::fitting::internal
