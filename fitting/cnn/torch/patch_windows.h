#pragma once
// The CNN's input with its kPatchHalo border (fitting/cnn/cnn.h): the whole material edge-replicated
// for dense inference, and one training tile's window of it. Both must give the same values, or
// training would show the network borders that inference never does. Included by cnn_net.cc,
// cnn_trainer.cc and their test only (ATen, not all of torch).

#include <cstdint>

#include <ATen/ATen.h>

namespace loom::fitting::internal {

// 1 × C × H × W → 1 × C × (H + 2 halo) × (W + 2 halo), edge pixels replicated (corners the
// corner pixel), as copies rather than ATen's replication_pad2d, which took 2.7 s of a 630²
// paper-size input.
at::Tensor EdgePadded(const at::Tensor& input, int64_t halo);

// The window of `tile` × `tile` outputs at (x, y) of an unpadded 1 × C × H × W input with its
// `halo` border: EdgePadded(input, halo)'s window at (x, y), gathered without padding the whole
// material (a training set keeps its materials unpadded: padded, a 1,656-fabric tac7 set did
// not fit in 24 GB).
at::Tensor TileWindow(const at::Tensor& input, int x, int y, int tile, int64_t halo);

}  // namespace loom::fitting::internal
