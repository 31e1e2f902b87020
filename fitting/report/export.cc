#include "fitting/report/export.h"

#include <algorithm>
#include <cmath>

#include <png.h>
#include <opencv2/core.hpp>

#include "core/file_io.h"
#include "core/geometry.h"
#include "core/srgb.h"
#include "core/version.h"
#include "fitting/io/axf_export.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/report/internal/png.h"

namespace loom::fitting {
namespace {

// OpenCV stores BGR.
cv::Vec3b Bgr(double r, double g, double b) { return {ToSrgb8(b), ToSrgb8(g), ToSrgb8(r)}; }

// α ∈ (−π/2, π/2] around a colour wheel (α and α + π are the same lobe, so half a turn is all).
cv::Vec3b Hue(double alpha) {
  const double t = (alpha + kPi / 2) / kPi;
  const auto wave = [&](double phase) { return static_cast<uint8_t>(255 * (0.5 + 0.5 * std::cos(2 * kPi * (t - phase)))); };
  return {wave(2.0 / 3), wave(1.0 / 3), wave(0)};
}

using internal::Unit8;

}  // namespace

namespace internal {

uint8_t Unit8(double v) { return static_cast<uint8_t>(std::lround(255 * std::clamp(v, 0.0, 1.0))); }

Status WritePng(const std::filesystem::path& path, const cv::Mat& image) {
  if (image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3) || !image.isContinuous()) {
    return InternalError(path.string(), "a PNG is written from 8-bit grey or BGR pixels");
  }
  // Encoded in memory and written through a temporary file, so that every write is checked and
  // the file appears only whole. libpng rather than OpenCV's imgcodecs: the GPU build, whose
  // machine lacks imgcodecs' many codecs, writes the same previews.
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.cols);
  png.height = static_cast<png_uint_32>(image.rows);
  png.format = image.channels() == 3 ? PNG_FORMAT_BGR : PNG_FORMAT_GRAY;
  png_alloc_size_t size = 0;
  if (!png_image_write_get_memory_size(png, size, /*convert_to_8_bit=*/0, image.data, /*row_stride=*/0, nullptr)) {
    return IoError(path.string(), std::string("cannot encode the PNG: ") + png.message);
  }
  std::string encoded(size, '\0');
  if (!png_image_write_to_memory(&png, encoded.data(), &size, 0, image.data, 0, nullptr)) {
    return IoError(path.string(), std::string("cannot encode the PNG: ") + png.message);
  }
  encoded.resize(size);
  return WriteFileAtomically(path, encoded);
}

}  // namespace internal

uint8_t ToSrgb8(double linear) {
  const double v = std::clamp(linear, 0.0, 1.0);
  return static_cast<uint8_t>(std::lround(255 * SrgbEncode(v)));
}

const std::vector<std::string>& SvbrdfPreviewNames() {
  static const std::vector<std::string> names = {"diffuse", "specular", "normal", "sigma", "alpha", "height"};
  return names;
}

namespace {

// A parameter that is not a number would reach a renderer as garbage: such maps are refused,
// but for a pixel NaN in every parameter, which the fit skipped (masked or unseen).
Status CheckFiniteParameters(const Image& maps, const std::filesystem::path& path) {
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) {
      if (IsSkippedPixel(maps, x, y)) continue;
      for (int c = 0; c < kNumWardParams; ++c) {
        if (std::isfinite(maps.at(c, y, x))) continue;
        return InvalidArgumentError(path.string(), std::string("not written: ") + kSvbrdfChannels[c] + " at pixel (" +
                                                       std::to_string(x) + ", " + std::to_string(y) + ") is not a finite number");
      }
    }
  }
  return Status::Ok();
}

}  // namespace

int BlackenSkippedPixels(Image& maps) {
  WardParams<double> black;
  black.n_s = Eigen::Vector3d::UnitZ();
  black.a_d = black.a_s = Eigen::Vector3d::Zero();
  black.sigma_x = black.sigma_y = 1;
  black.alpha = 0;
  black.f0 = 1;
  int count = 0;
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) {
      if (IsSkippedPixel(maps, x, y)) SetParams(maps, x, y, black), ++count;
    }
  }
  return count;
}

Status WriteSvbrdf(const std::filesystem::path& dir, const Image& maps, const SvbrdfProvenance& provenance) {
  LOOM_RETURN_IF_ERROR(CheckFiniteParameters(maps, dir / "svbrdf.exr"));
  LOOM_RETURN_IF_ERROR(CreateDirectories(dir));
  LOOM_RETURN_IF_ERROR(WriteExr(dir / "svbrdf.exr", maps,
                                {{"loom.kind", std::string("svbrdf maps")},
                                 {"loom.method", provenance.method},
                                 {"loom.stack", provenance.stack},
                                 {"loom.rig", provenance.rig},
                                 {"loom.pixel_mm", provenance.pixel_mm},
                                 {"loom.units", std::string("albedos linear sRGB; sigma unitless; alpha rad; height mm")},
                                 {"loom.version", std::string(VersionWithCommit())}}));
  return WriteSvbrdfPreviews(maps, dir);
}

Status WriteSvbrdfPreviews(const Image& maps, const std::filesystem::path& dir, const std::string& prefix) {
  const int w = maps.width();
  const int h = maps.height();
  cv::Mat diffuse(h, w, CV_8UC3), specular(h, w, CV_8UC3), normal(h, w, CV_8UC3), sigma(h, w, CV_8UC3), alpha(h, w, CV_8UC3),
      height(h, w, CV_8UC1);
  const std::optional<int> height_channel = maps.FindChannel(kHeightChannel);
  float max_height = 1e-6f;
  if (height_channel) {
    for (float v : maps.channel(*height_channel)) max_height = std::max(max_height, v);
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (IsSkippedPixel(maps, x, y)) {  // black in every preview
        for (cv::Mat* m : {&diffuse, &specular, &normal, &sigma, &alpha}) m->at<cv::Vec3b>(y, x) = {0, 0, 0};
        height.at<uint8_t>(y, x) = 0;
        continue;
      }
      const WardParams<double> p = GetParams(maps, x, y);
      diffuse.at<cv::Vec3b>(y, x) = Bgr(p.a_d.x(), p.a_d.y(), p.a_d.z());
      specular.at<cv::Vec3b>(y, x) = Bgr(p.a_s.x(), p.a_s.y(), p.a_s.z());
      const Eigen::Vector3d n = p.n_s * 0.5 + Eigen::Vector3d::Constant(0.5);
      normal.at<cv::Vec3b>(y, x) = {Unit8(n.z()), Unit8(n.y()), Unit8(n.x())};
      sigma.at<cv::Vec3b>(y, x) = {0, Unit8(p.sigma_y), Unit8(p.sigma_x)};
      alpha.at<cv::Vec3b>(y, x) = Hue(p.alpha);
      height.at<uint8_t>(y, x) = height_channel ? Unit8(maps.at(*height_channel, y, x) / max_height) : 0;
    }
  }
  const cv::Mat* images[] = {&diffuse, &specular, &normal, &sigma, &alpha, &height};
  for (size_t i = 0; i < SvbrdfPreviewNames().size(); ++i) {
    if (SvbrdfPreviewNames()[i] == "height" && !height_channel) continue;
    LOOM_RETURN_IF_ERROR(internal::WritePng(dir / (prefix + SvbrdfPreviewNames()[i] + ".png"), *images[i]));
  }
  return Status::Ok();
}

Status WriteRadiancePng(const std::filesystem::path& path, const Image& image, int channel, double white) {
  cv::Mat png(image.height(), image.width(), CV_8UC3);
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const float v = image.at(channel, y, x);
      png.at<cv::Vec3b>(y, x) = std::isnan(v) ? cv::Vec3b(255, 0, 255) : Bgr(v / white, v / white, v / white);
    }
  }
  return internal::WritePng(path, png);
}

}  // namespace loom::fitting
