#include "core/image.h"

#include <algorithm>
#include <limits>
#include <unordered_set>

#include "core/check.h"

namespace loom {

Image::Image(int width, int height, std::vector<std::string> channel_names)
    : width_(width), height_(height), channel_names_(std::move(channel_names)) {
  LOOM_CHECK(width >= 0 && height >= 0) << "image size " << width << "x" << height;
  std::unordered_set<std::string_view> seen;
  for (const std::string& name : channel_names_) {
    LOOM_CHECK(seen.insert(name).second) << "duplicate channel name '" << name << "'";
  }
  data_.assign(pixel_count() * channel_names_.size(), 0.0f);
}

const std::string& Image::channel_name(int c) const {
  LOOM_CHECK(c >= 0 && c < num_channels()) << "channel " << c << " of " << num_channels();
  return channel_names_[c];
}

std::optional<int> Image::FindChannel(std::string_view name) const {
  for (int c = 0; c < num_channels(); ++c) {
    if (channel_names_[c] == name) return c;
  }
  return std::nullopt;
}

Result<int> Image::ChannelIndex(std::string_view name) const {
  if (std::optional<int> c = FindChannel(name)) return *c;
  std::string known;
  for (int c = 0; c < num_channels() && c < 8; ++c) {
    known += (c ? ", " : "") + channel_names_[c];
  }
  if (num_channels() > 8) known += ", ...";
  return NotFoundError("channel '" + std::string(name) + "'",
                       "not in image (channels: " + (known.empty() ? "none" : known) + ")");
}

std::vector<int> Image::ChannelsWithPrefix(std::string_view prefix) const {
  std::vector<int> indices;
  for (int c = 0; c < num_channels(); ++c) {
    if (channel_names_[c].starts_with(prefix)) indices.push_back(c);
  }
  return indices;
}

int Image::AddChannel(std::string name) {
  LOOM_CHECK(!FindChannel(name)) << "duplicate channel name '" << name << "'";
  channel_names_.push_back(std::move(name));
  data_.resize(data_.size() + pixel_count(), 0.0f);
  return num_channels() - 1;
}

std::span<float> Image::channel(int c) {
  LOOM_CHECK(c >= 0 && c < num_channels()) << "channel " << c << " of " << num_channels();
  return {data_.data() + static_cast<size_t>(c) * pixel_count(), pixel_count()};
}

std::span<const float> Image::channel(int c) const {
  LOOM_CHECK(c >= 0 && c < num_channels()) << "channel " << c << " of " << num_channels();
  return {data_.data() + static_cast<size_t>(c) * pixel_count(), pixel_count()};
}

float SampleBilinear(const Image& image, int c, double x, double y) {
  if (!(x >= 0 && y >= 0 && x <= image.width() - 1 && y <= image.height() - 1)) return std::numeric_limits<float>::quiet_NaN();
  const int x0 = std::min(static_cast<int>(x), std::max(0, image.width() - 2));
  const int y0 = std::min(static_cast<int>(y), std::max(0, image.height() - 2));
  const int x1 = std::min(x0 + 1, image.width() - 1);
  const int y1 = std::min(y0 + 1, image.height() - 1);
  const double fx = x - x0;
  const double fy = y - y0;
  return static_cast<float>((1 - fy) * ((1 - fx) * image.at(c, y0, x0) + fx * image.at(c, y0, x1)) +
                            fy * ((1 - fx) * image.at(c, y1, x0) + fx * image.at(c, y1, x1)));
}

}  // namespace loom
