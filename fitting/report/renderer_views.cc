#include "fitting/report/renderer_views.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "core/file_io.h"
#include "fitting/io/internal/geometric_frame.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/model/ward_gd10.h"
#include "fitting/report/evaluation.h"
#include "fitting/report/export.h"
#include "fitting/report/internal/png.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

// Where pixel (x, y) of a W × H grid lies on the flat quad (core/observation_stack.h's grid).
Eigen::Vector3d OnTheQuad(int x, int y, int width, int height, double pixel_mm) {
  return {(x + 0.5 - width / 2.0) * pixel_mm, (y + 0.5 - height / 2.0) * pixel_mm, 0};
}

nlohmann::json GltfVector(const Eigen::Vector3d& in_sample, double scale) {
  return {in_sample.x() * scale, in_sample.z() * scale, -in_sample.y() * scale};
}

double Percentile99(const Image& image) {
  std::vector<float> values(image.data(), image.data() + image.pixel_count() * image.num_channels());
  if (values.empty()) return 1;
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(0.99 * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), at, values.end());
  return std::max(1e-12, static_cast<double>(*at));
}

Status WriteRgbPng(const fs::path& path, const Image& rgb, double white) {
  cv::Mat png(rgb.height(), rgb.width(), CV_8UC3);
  for (int y = 0; y < rgb.height(); ++y) {
    for (int x = 0; x < rgb.width(); ++x) {
      png.at<cv::Vec3b>(y, x) = {ToSrgb8(rgb.at(2, y, x) / white), ToSrgb8(rgb.at(1, y, x) / white),
                                 ToSrgb8(rgb.at(0, y, x) / white)};
    }
  }
  return internal::WritePng(path, png);
}

Status WriteFloats(const fs::path& path, const Image& rgb) {
  std::string bytes(rgb.pixel_count() * 3 * sizeof(float), '\0');
  float* out = reinterpret_cast<float*>(bytes.data());
  for (int y = 0; y < rgb.height(); ++y) {
    for (int x = 0; x < rgb.width(); ++x) {
      for (int c = 0; c < 3; ++c) *out++ = rgb.at(c, y, x);
    }
  }
  return WriteFileAtomically(path, bytes);
}

}  // namespace

std::vector<RendererView> ChooseRendererViews(const ObservationStack& stack, int count) {
  std::vector<std::pair<double, int>> by_brightness;
  for (size_t k = 0; k < stack.observations.size(); ++k) {
    // One point light seen from a camera centre: the views a renderer's scene can reproduce.
    const StackObservation& o = stack.observations[k];
    if (o.emitters.size() != 1 || o.emitters.front().at_infinity || o.view_direction) continue;
    by_brightness.push_back({MeanObservedRadiance(stack, static_cast<int>(k)), static_cast<int>(k)});
  }
  std::sort(by_brightness.rbegin(), by_brightness.rend());
  std::vector<RendererView> views;
  const int n = std::min(count, static_cast<int>(by_brightness.size()));
  for (int i = 0; i < n; ++i) {
    // Quadratic spacing: several of the brightest (highlights), then down to the median.
    const double fraction = 0.5 * (static_cast<double>(i) / std::max(1, n - 1)) * (static_cast<double>(i) / std::max(1, n - 1));
    const int k = by_brightness[static_cast<size_t>(fraction * static_cast<double>(by_brightness.size() - 1))].second;
    const StackObservation& o = stack.observations[k];
    const PointEmitter& emitter = o.emitters.front();
    views.push_back({k, emitter.position_mm, emitter.IntensityTowards(Eigen::Vector3d::Zero()), o.camera_mm.normalized()});
  }
  return views;
}

Image RenderView(const Image& maps, double pixel_mm, const RendererView& view) {
  Image rgb(maps.width(), maps.height(), {"R", "G", "B"});
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) {
      const Eigen::Vector3d to_light = view.light_mm - OnTheQuad(x, y, maps.width(), maps.height(), pixel_mm);
      const double irradiance = view.intensity / to_light.squaredNorm();
      const Eigen::Matrix3d sample_from_local = internal::SampleFromLocal(maps, x, y, pixel_mm);
      const Eigen::Vector3d l = sample_from_local.transpose() * to_light.normalized();
      const Eigen::Vector3d v = sample_from_local.transpose() * view.view;
      const Eigen::Vector3d radiance = EvaluateWardCos(GetParams(maps, x, y), l, v) * irradiance;
      for (int c = 0; c < 3; ++c) rgb.at(c, y, x) = static_cast<float>(radiance[c]);
    }
  }
  return rgb;
}

Status WriteRendererViews(const fs::path& dir, const Image& maps, double pixel_mm, const ObservationStack& stack,
                          const std::vector<RendererView>& views) {
  LOOM_RETURN_IF_ERROR(CreateDirectories(dir));
  nlohmann::json document = {{"width", maps.width()}, {"height", maps.height()}, {"pixel_mm", pixel_mm}};
  document["views"] = nlohmann::json::array();
  for (const RendererView& view : views) {
    const std::string name = stack.image.channel_name(ObservationStack::ObservationChannel(view.observation));
    const Image rendered = RenderView(maps, pixel_mm, view);
    const double white = Percentile99(rendered);
    LOOM_RETURN_IF_ERROR(WriteFloats(dir / ("loom-" + name + ".f32"), rendered));
    LOOM_RETURN_IF_ERROR(WriteRgbPng(dir / ("loom-" + name + ".png"), rendered, white));
    document["views"].push_back({
        {"name", name},
        {"description", stack.observations[view.observation].description},
        {"light_mm", {view.light_mm.x(), view.light_mm.y(), view.light_mm.z()}},
        {"view", {view.view.x(), view.view.y(), view.view.z()}},
        {"intensity", view.intensity},
        {"gltf", {{"light_m", GltfVector(view.light_mm, 1e-3)}, {"view", GltfVector(view.view, 1)}}},
        {"threejs_intensity", view.intensity * 1e-6},
        {"loom", "loom-" + name + ".f32"},
        {"loom_png", "loom-" + name + ".png"},
        {"white", white},
    });
  }
  return WriteFileAtomically(dir / "views.json", document.dump(2) + "\n");
}

}  // namespace loom::fitting
