// Steps 1–3 of the whole-stack fit: the pixels clustered by appearance and each cluster fitted.
#include "fitting/solve/internal/stack_stages.h"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "core/parallel.h"
#include "fitting/solve/internal/normal_frame.h"

namespace loom::fitting::internal {

namespace {

// log(1 + L / typical) of the pixels `rows` (indices into the stack): compresses highlights so
// that k-means groups by appearance, not by the few brightest observations.
cv::Mat AppearanceFeatures(const ObservationStack& stack, const std::vector<int>& rows) {
  const int n = static_cast<int>(stack.observations.size());
  const auto value = [&](int k, int i) {
    return stack.image.channel(ObservationStack::ObservationChannel(k))[static_cast<size_t>(i)];
  };
  std::vector<float> finite;
  for (int k = 0; k < n; ++k) {
    for (int i : rows) {
      if (const float v = value(k, i); std::isfinite(v) && v > 0) finite.push_back(v);
    }
  }
  float typical = 1;
  if (!finite.empty()) {
    std::nth_element(finite.begin(), finite.begin() + finite.size() / 2, finite.end());
    typical = finite[finite.size() / 2];
  }
  cv::Mat features(static_cast<int>(rows.size()), n, CV_32F);
  for (int k = 0; k < n; ++k) {
    double sum = 0;
    int seen = 0;
    for (int i : rows) {
      if (const float v = value(k, i); std::isfinite(v)) sum += std::log1p(std::max(0.0f, v) / typical), ++seen;
    }
    const float unseen = seen ? static_cast<float>(sum / seen) : 0.0f;
    for (size_t r = 0; r < rows.size(); ++r) {
      const float v = value(k, rows[r]);
      features.at<float>(static_cast<int>(r), k) = std::isfinite(v) ? std::log1p(std::max(0.0f, v) / typical) : unseen;
    }
  }
  return features;
}

// The pixels that a fit can use: those with at least as many seen observations as GD10 has
// parameters. The others (masked, as an imported photograph's background is, or unseen by the
// cameras) are skipped: NaN maps, counted, never an error.
std::vector<int> FittablePixels(const ObservationStack& stack) {
  const int pixels = static_cast<int>(stack.image.pixel_count());
  std::vector<int> seen(pixels, 0);
  for (size_t k = 0; k < stack.observations.size(); ++k) {
    const auto values = stack.image.channel(ObservationStack::ObservationChannel(static_cast<int>(k)));
    for (int i = 0; i < pixels; ++i) seen[i] += !std::isnan(values[i]);
  }
  std::vector<int> fittable;
  for (int i = 0; i < pixels; ++i) {
    if (seen[i] >= kNumWardParams) fittable.push_back(i);
  }
  return fittable;
}

// The cluster's start: its most typical pixels' observations pooled into one fit, each pixel's
// turned onto its photometric-stereo normal where it has one (the fit's n_s is then relative
// to each pixel's normal).
Result<PixelFitResult> FitCluster(const StackPixels& pixels, const PixelClusters& clusters, int cluster,
                                  const StackFitOptions& options, const NormalStarts& normals) {
  std::vector<std::pair<float, int>> members;
  for (size_t i = 0; i < clusters.labels.size(); ++i) {
    if (clusters.labels[i] == cluster) members.push_back({clusters.distances[i], static_cast<int>(i)});
  }
  const size_t take = std::min(members.size(), static_cast<size_t>(options.pixels_per_cluster_fit));
  std::partial_sort(members.begin(), members.begin() + take, members.end());
  std::vector<PixelObservation> pooled;
  for (size_t m = 0; m < take; ++m) {
    const int i = members[m].second;
    std::vector<PixelObservation> own = pixels.Observations(i % pixels.width(), i / pixels.width());
    if (const std::optional<Eigen::Matrix3d> turn = normals.Turn(i)) internal::TurnObservations(*turn, own);
    pooled.insert(pooled.end(), std::make_move_iterator(own.begin()), std::make_move_iterator(own.end()));
  }
  PixelFitOptions fit = options.cluster_fit;
  fit.fixed_f0 = options.fixed_f0;
  return FitFromStarts(pooled, GridInitialParams(pooled, options.fixed_f0.value_or(1.0), options.grid_starts), fit);
}

}  // namespace

// Steps 1–3: every cluster's fit (the material's F0 is searched after, SearchF0).
Status FitClusters(const StackPixels& pixels, const PixelClusters& clusters, const StackFitOptions& options,
                   const NormalStarts& normals, const std::function<void(int)>& progress, StackFitSummary& summary) {
  std::vector<Result<PixelFitResult>> cluster_fits(clusters.count, InternalError("cluster", "not fitted"));
  ParallelFor(
      clusters.count, options.threads, [&](int c) { cluster_fits[c] = FitCluster(pixels, clusters, c, options, normals); },
      progress);
  summary.cluster_sizes.assign(clusters.count, 0);
  for (int label : clusters.labels) {
    if (label >= 0) ++summary.cluster_sizes[label];
  }
  for (int c = 0; c < clusters.count; ++c) {
    if (!cluster_fits[c].ok()) {
      return FailedPreconditionError("cluster " + std::to_string(c) + " of the stack", cluster_fits[c].status().ToString());
    }
    summary.cluster_params.push_back(cluster_fits[c]->params);
  }
  return {};
}

}  // namespace loom::fitting::internal

namespace loom::fitting {

PixelClusters ClusterPixels(const ObservationStack& stack, int clusters, uint64_t seed) {
  const std::vector<int> fittable = internal::FittablePixels(stack);
  const cv::Mat features = internal::AppearanceFeatures(stack, fittable);
  PixelClusters result;
  result.count = std::min(clusters, features.rows);
  result.labels.assign(stack.image.pixel_count(), -1);
  result.distances.assign(stack.image.pixel_count(), 0);
  for (int i : fittable) result.labels[i] = 0;
  if (result.count <= 1) return result;
  cv::Mat labels, centres;
  cv::theRNG().state = seed;  // k-means++ seeding draws from OpenCV's thread-local generator
  cv::kmeans(features, result.count, labels, cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4), 3,
             cv::KMEANS_PP_CENTERS, centres);
  for (int r = 0; r < features.rows; ++r) {
    const int i = fittable[r];
    result.labels[i] = labels.at<int>(r);
    result.distances[i] = static_cast<float>(cv::norm(features.row(r), centres.row(result.labels[i])));
  }
  return result;
}

}  // namespace loom::fitting
