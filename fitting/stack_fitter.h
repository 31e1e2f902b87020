#pragma once
// The Ceres fit of a whole observation stack, in the paper's reference pipeline's order:
//  1. cluster the pixels by appearance (k-means on their log radiances, OpenCV);
//  2. fit each cluster on the pooled observations of its most typical pixels — many more
//     angular samples than one pixel has, from a generic start with the α multi-start;
//  3. one F0 for the material (the clusters' median, weighted by size), as Pantora fits it:
//     away from grazing angles only a_s·F0 is observable per pixel;
//  4. fit every pixel from its cluster's parameters (a_s rescaled to keep a_s·F0), threaded.
// A pixel with too few usable observations keeps its cluster's parameters and is counted.
//
// Output maps: svbrdf_maps.h's 13 channels and `height` (the stack's pos.Z), then
// fit.cluster (index), fit.observations (used), fit.rms (RMS residual relative to the pixel's
// mean radiance).

#include <functional>
#include <vector>

#include "core/image.h"
#include "core/observation_stack.h"
#include "fitting/pixel_fitter.h"
#include "fitting/stack_pixels.h"

namespace loom::fitting {

struct StackFitProgress {
  std::string stage;  // "clusters", "pixels"
  int done = 0;
  int total = 0;
};

struct StackFitOptions {
  int clusters = 8;                 // k-means clusters (1: one start for the whole material)
  int pixels_per_cluster_fit = 12;  // most typical pixels pooled into a cluster's fit
  PixelFitOptions cluster_fit = {.max_iterations = 100, .multi_start = true};
  PixelFitOptions pixel_fit = {.max_iterations = 30, .multi_start = false};
  bool one_f0_per_material = true;  // false: F0 free per pixel (then only a_s·F0 is meaningful)
  StackPixelOptions pixels;
  int threads = 0;                  // 0: one per core
  uint64_t seed = 1;                // k-means initialisation
  std::function<void(const StackFitProgress&)> progress;  // on the calling thread
  Status Check() const;             // every problem, naming the field
};

struct StackFitSummary {
  int pixels = 0;
  int pixels_fitted = 0;
  int pixels_kept_at_cluster = 0;   // too few usable observations
  std::vector<WardParams<double>> cluster_params;
  std::vector<int> cluster_sizes;
  double f0 = 0;                    // the material's (or the median over pixels)
  double mean_iterations = 0;       // per pixel fit
  double mean_observations = 0;     // usable per pixel
  double cluster_seconds = 0;
  double pixel_seconds = 0;
  int threads = 0;
  double ms_per_pixel_per_thread() const { return pixels ? 1e3 * pixel_seconds * threads / pixels : 0; }
};

struct StackFit {
  Image maps;
  StackFitSummary summary;
};

inline constexpr const char* kFitClusterChannel = "fit.cluster";
inline constexpr const char* kFitObservationsChannel = "fit.observations";
inline constexpr const char* kFitRmsChannel = "fit.rms";

Result<StackFit> FitStack(const ObservationStack& stack, const StackFitOptions& options = {});

// The appearance clusters: k-means on each pixel's log radiances (an unseen value takes that
// observation's mean over the stack). Row-major per pixel: its cluster and its distance to the
// cluster's centre (small = typical).
struct PixelClusters {
  int count = 0;
  std::vector<int> labels;
  std::vector<float> distances;
};
PixelClusters ClusterPixels(const ObservationStack& stack, int clusters, uint64_t seed);

}  // namespace loom::fitting
