#include "fitting/cnn/torch/patch_windows.h"

namespace loom::fitting::internal {

at::Tensor EdgePadded(const at::Tensor& input, int64_t halo) {
  const int64_t c = input.size(1), h = input.size(2), w = input.size(3), k = halo;
  at::Tensor padded = at::empty({1, c, h + 2 * k, w + 2 * k}, input.options());
  at::Tensor rows = padded.narrow(2, k, h);
  rows.narrow(3, k, w).copy_(input);
  rows.narrow(3, 0, k).copy_(input.narrow(3, 0, 1).expand({1, c, h, k}));
  rows.narrow(3, k + w, k).copy_(input.narrow(3, w - 1, 1).expand({1, c, h, k}));
  // Whole padded rows, so the corners take the corner pixel.
  padded.narrow(2, 0, k).copy_(padded.narrow(2, k, 1).expand({1, c, k, w + 2 * k}));
  padded.narrow(2, k + h, k).copy_(padded.narrow(2, k + h - 1, 1).expand({1, c, k, w + 2 * k}));
  return padded;
}

at::Tensor TileWindow(const at::Tensor& input, int x, int y, int tile, int64_t halo) {
  const auto indices = [&](int first, int64_t extent) {
    const auto options = at::TensorOptions().dtype(at::kLong).device(input.device());
    return at::arange(first - halo, first + tile + halo, options).clamp(0, extent - 1);
  };
  return input.index_select(2, indices(y, input.size(2))).index_select(3, indices(x, input.size(3)));
}

}  // namespace loom::fitting::internal
