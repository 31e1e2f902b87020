#pragma once
// Image: a planar float image with named channels — the in-memory form of everything loom
// stores in OpenEXR (raw frames after conversion, HDR stacks with ~1000 channels, SVBRDF maps).
//
// Layout: channel-major planes, row-major inside a plane:
//   data[c * width * height + y * width + x]
// so one channel is one contiguous span (what EXR slices, per-channel statistics and the CNN's
// NCHW tensors want). Channel names are unique and follow EXR's "layer.channel" convention
// where there are layers ("a_d.R", "a_d.G", "sigma_x").
// Thread-safety: a value type; concurrent reads are safe, writes need external locking.

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"

namespace loom {

class Image {
 public:
  Image() = default;
  // Zero-filled. Names must be unique (CHECKed).
  Image(int width, int height, std::vector<std::string> channel_names);

  int width() const { return width_; }
  int height() const { return height_; }
  int num_channels() const { return static_cast<int>(channel_names_.size()); }
  size_t pixel_count() const { return static_cast<size_t>(width_) * height_; }
  bool empty() const { return pixel_count() == 0 || channel_names_.empty(); }

  const std::vector<std::string>& channel_names() const { return channel_names_; }
  const std::string& channel_name(int c) const;
  std::optional<int> FindChannel(std::string_view name) const;
  // NotFound naming the channel (and listing a few that exist) when absent.
  Result<int> ChannelIndex(std::string_view name) const;
  // Indices of the channels whose names start with `prefix` ("a_d." → a_d.R, a_d.G, a_d.B).
  std::vector<int> ChannelsWithPrefix(std::string_view prefix) const;

  // Appends a zero-filled channel; returns its index. The name must be new (CHECKed).
  int AddChannel(std::string name);

  std::span<float> channel(int c);
  std::span<const float> channel(int c) const;
  float& at(int c, int y, int x) { return data_[Offset(c, y, x)]; }
  float at(int c, int y, int x) const { return data_[Offset(c, y, x)]; }

  float* data() { return data_.data(); }
  const float* data() const { return data_.data(); }

 private:
  size_t Offset(int c, int y, int x) const { return (static_cast<size_t>(c) * height_ + y) * width_ + x; }

  int width_ = 0;
  int height_ = 0;
  std::vector<std::string> channel_names_;
  std::vector<float> data_;
};

// Channel `c` at subpixel (x, y), bilinear between pixel centres (integers); NaN off the image
// (beyond the outer pixel centres) or where a neighbour is NaN.
float SampleBilinear(const Image& image, int c, double x, double y);

}  // namespace loom
