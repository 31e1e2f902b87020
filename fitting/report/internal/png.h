#pragma once
// Writing 8-bit PNGs (libpng) from OpenCV's images, for the exporters (export.cc, gltf_export.cc).

#include <filesystem>

#include <opencv2/core.hpp>

#include "core/status.h"

namespace loom::fitting::internal {

// `image` is BGR (OpenCV's order) or grey; errors name the file.
Status WritePng(const std::filesystem::path& path, const cv::Mat& image);

// [0, 1] → 0..255, clamped.
uint8_t Unit8(double v);

}  // namespace loom::fitting::internal
