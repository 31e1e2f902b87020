#include "fitting/model/svbrdf_maps.h"

#include <cmath>
#include <variant>
#include <vector>

#include "core/exr_io.h"

namespace loom::fitting {

Image MakeSvbrdfImage(int width, int height, bool with_height) {
  std::vector<std::string> names(kSvbrdfChannels.begin(), kSvbrdfChannels.end());
  if (with_height) names.emplace_back(kHeightChannel);
  return Image(width, height, names);
}

bool HasSvbrdfLayout(const Image& maps) {
  if (maps.num_channels() < kNumWardParams) return false;
  for (int c = 0; c < kNumWardParams; ++c) {
    if (maps.channel_name(c) != kSvbrdfChannels[c]) return false;
  }
  return true;
}

bool IsSkippedPixel(const Image& maps, int x, int y) {
  for (int c = 0; c < kNumWardParams; ++c) {
    if (!std::isnan(maps.at(c, y, x))) return false;
  }
  return true;
}

WardParams<double> GetParams(const Image& maps, int x, int y) {
  WardParams<double> p;
  for (int i = 0; i < 3; ++i) {
    p.n_s[i] = maps.at(i, y, x);
    p.a_d[i] = maps.at(3 + i, y, x);
    p.a_s[i] = maps.at(6 + i, y, x);
  }
  p.sigma_x = maps.at(9, y, x);
  p.sigma_y = maps.at(10, y, x);
  p.alpha = maps.at(11, y, x);
  p.f0 = maps.at(12, y, x);
  return p;
}

void SetParams(Image& maps, int x, int y, const WardParams<double>& p) {
  for (int i = 0; i < 3; ++i) {
    maps.at(i, y, x) = static_cast<float>(p.n_s[i]);
    maps.at(3 + i, y, x) = static_cast<float>(p.a_d[i]);
    maps.at(6 + i, y, x) = static_cast<float>(p.a_s[i]);
  }
  maps.at(9, y, x) = static_cast<float>(p.sigma_x);
  maps.at(10, y, x) = static_cast<float>(p.sigma_y);
  maps.at(11, y, x) = static_cast<float>(p.alpha);
  maps.at(12, y, x) = static_cast<float>(p.f0);
}

Result<SvbrdfFile> ReadSvbrdfExr(const std::filesystem::path& path) {
  LOOM_ASSIGN_OR_RETURN(ExrImage exr, ReadExr(path));
  if (!HasSvbrdfLayout(exr.image)) {
    return InvalidArgumentError(path.string(), "not SVBRDF maps: the first channels must be n_s.X ... F0");
  }
  SvbrdfFile file{std::move(exr.image), 0};
  if (const auto it = exr.attributes.find("loom.pixel_mm"); it != exr.attributes.end()) {
    if (const double* mm = std::get_if<double>(&it->second)) file.pixel_mm = *mm;
  }
  return file;
}

}  // namespace loom::fitting
