#include "fitting/view_selection.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <map>

#include "core/duration.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/report/evaluation.h"

namespace loom::fitting {
namespace {

// What makes two observations one view: the camera and every light, exactly.
std::vector<double> ViewKey(const StackObservation& o) {
  const Eigen::Vector3d camera = o.view_direction ? *o.view_direction : o.camera_mm;
  std::vector<double> key = {o.view_direction ? 1.0 : 0.0, camera.x(), camera.y(), camera.z()};
  for (const PointEmitter& e : o.emitters) {
    const Eigen::Vector3d where = e.at_infinity ? Eigen::Vector3d(-e.axis) : e.position_mm;
    key.insert(key.end(), {e.at_infinity ? 1.0 : 0.0, where.x(), where.y(), where.z()});
  }
  return key;
}

// Per pixel, Σ |predicted − measured| over the observations `held` of `stack`; +∞ where the
// maps skipped a pixel that has measured values (a model that predicts nothing there loses).
std::vector<double> PixelErrors(const Image& maps, const ObservationStack& stack, const std::vector<int>& held) {
  const Image predicted = RenderObservations(maps, stack, held);
  std::vector<double> errors(stack.image.pixel_count(), 0);
  const int width = stack.image.width();
  for (size_t h = 0; h < held.size(); ++h) {
    const auto measured = stack.image.channel(ObservationStack::ObservationChannel(held[h]));
    const auto rendered = predicted.channel(static_cast<int>(h));
    for (size_t i = 0; i < errors.size(); ++i) {
      if (std::isnan(measured[i])) continue;
      if (IsSkippedPixel(maps, static_cast<int>(i) % width, static_cast<int>(i) / width)) {
        errors[i] = std::numeric_limits<double>::infinity();
      } else if (!std::isnan(rendered[i])) {
        errors[i] += std::abs(rendered[i] - measured[i]);
      }
    }
  }
  return errors;
}

// Per pixel, Σ |measured| over the observations `held`, added to `sums`.
void AddMeasured(const ObservationStack& stack, const std::vector<int>& held, std::vector<double>& sums) {
  for (int k : held) {
    const auto values = stack.image.channel(ObservationStack::ObservationChannel(k));
    for (size_t i = 0; i < sums.size(); ++i) {
      if (!std::isnan(values[i])) sums[i] += std::abs(values[i]);
    }
  }
}

}  // namespace

std::vector<std::vector<int>> StackViews(const ObservationStack& stack) {
  std::vector<std::vector<double>> keys;
  std::vector<std::vector<int>> views;
  for (int k = 0; k < static_cast<int>(stack.observations.size()); ++k) {
    const std::vector<double> key = ViewKey(stack.observations[k]);
    const auto found = std::find(keys.begin(), keys.end(), key);
    if (found == keys.end()) {
      keys.push_back(key);
      views.push_back({k});
    } else {
      views[found - keys.begin()].push_back(k);
    }
  }
  return views;
}

Result<ViewSelection> SelectByLeftOutViews(const ObservationStack& stack, const StackMapsFit& gd10, const StackMapsFit& lambert) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<std::vector<int>> views = StackViews(stack);
  const size_t pixels = stack.image.pixel_count();
  // Per view left out, per pixel: each model's error on it.
  std::vector<std::vector<double>> gd10_errors, lambert_errors;
  std::vector<double> measured(pixels, 0);
  for (size_t v = 0; v < views.size(); ++v) {
    std::vector<int> kept;
    for (size_t w = 0; w < views.size(); ++w) {
      if (w != v) kept.insert(kept.end(), views[w].begin(), views[w].end());
    }
    const ObservationStack without = SelectObservations(stack, kept);
    LOOM_ASSIGN_OR_RETURN(const Image gd10_maps, gd10(without));
    LOOM_ASSIGN_OR_RETURN(const Image lambert_maps, lambert(without));
    gd10_errors.push_back(PixelErrors(gd10_maps, stack, views[v]));
    lambert_errors.push_back(PixelErrors(lambert_maps, stack, views[v]));
    AddMeasured(stack, views[v], measured);
  }
  const auto summed = [&](const std::vector<std::vector<double>>& by_view) {
    std::vector<double> sums(pixels, 0);
    for (const std::vector<double>& errors : by_view) {
      for (size_t i = 0; i < pixels; ++i) sums[i] += errors[i];
    }
    return sums;
  };
  const std::vector<double> gd10_error = summed(gd10_errors), lambert_error = summed(lambert_errors);
  ViewSelection selection;  // (the totals below: over the pixels both models predicted)
  selection.views = static_cast<int>(views.size());
  LOOM_ASSIGN_OR_RETURN(selection.maps, gd10(stack));
  LOOM_ASSIGN_OR_RETURN(const Image lambert_maps, lambert(stack));
  const int lambertian_channel = selection.maps.AddChannel(kLambertianChannel);
  // The choice per region of one appearance (the GD10 fit's clusters, fit.cluster), whose errors
  // are summed: one pixel's 8 or so left-out views choose by chance about as often as by merit
  // (per pixel the left-out views of a simulated fabric came out 1.4× a Lambertian surface's).
  const std::optional<int> cluster_channel = selection.maps.FindChannel("fit.cluster");
  const int width = stack.image.width();
  const auto region_of = [&](size_t i) {
    const int x = static_cast<int>(i) % width, y = static_cast<int>(i) / width;
    const float label = cluster_channel ? selection.maps.at(*cluster_channel, y, x) : -1.0f;
    return label >= 0 ? static_cast<long>(label) : -1 - static_cast<long>(i);  // no cluster: the pixel alone
  };
  // Per region: each model's error on each view left out over the pixels both predicted, and how
  // many pixels each failed to predict (skipped by its fit of some fold) where the other did. Where
  // both predicted at least as many pixels as the two failed on together, their errors there choose:
  // a model that fails on a few pixels (too few views left in a fold) loses those, not the region.
  // GD10 is kept where it predicted the region better on most of the views left out and its mean
  // gain over them is more than one standard error (paired view by view): its errors are
  // heavy-tailed (a highlight placed or missed), so a few views' placed highlights can win the sum
  // while it predicts the others worse, and a gain smaller than its spread over eight views says
  // as little about an unseen view as no gain. Elsewhere the model that predicted more pixels is
  // kept.
  struct RegionErrors {
    std::vector<double> gd10_views, lambert_views;
    int both = 0, gd10_failed = 0, lambert_failed = 0;
    bool Lambertian() const {
      if (both < gd10_failed + lambert_failed) return gd10_failed >= lambert_failed;
      size_t gd10_wins = 0;
      for (size_t v = 0; v < gd10_views.size(); ++v) gd10_wins += gd10_views[v] < lambert_views[v];
      return 2 * gd10_wins <= gd10_views.size() || Gd10GainInStandardErrors() <= 1;
    }
    // The mean over the left-out views of (Lambert's error − GD10's) over its standard error.
    double Gd10GainInStandardErrors() const {
      const double n = static_cast<double>(gd10_views.size());
      double sum = 0, squares = 0;
      for (size_t v = 0; v < gd10_views.size(); ++v) {
        const double gain = lambert_views[v] - gd10_views[v];
        sum += gain, squares += gain * gain;
      }
      const double mean = sum / n, variance = (squares - n * mean * mean) / (n - 1);
      return variance > 0 ? mean / std::sqrt(variance / n) : (mean > 0 ? INFINITY : 0);
    }
  };
  std::map<long, RegionErrors> regions;
  double all_gd10 = 0, all_lambert = 0, all_measured = 0;
  for (size_t i = 0; i < pixels; ++i) {
    RegionErrors& r = regions[region_of(i)];
    const bool g = std::isfinite(gd10_error[i]), l = std::isfinite(lambert_error[i]);
    r.gd10_failed += !g && l, r.lambert_failed += g && !l;
    if (!g || !l) continue;
    ++r.both;
    if (r.gd10_views.empty()) r.gd10_views.resize(views.size()), r.lambert_views.resize(views.size());
    for (size_t v = 0; v < views.size(); ++v) r.gd10_views[v] += gd10_errors[v][i], r.lambert_views[v] += lambert_errors[v][i];
    all_gd10 += gd10_error[i], all_lambert += lambert_error[i], all_measured += measured[i];
  }
  double chosen = 0;
  for (size_t i = 0; i < pixels; ++i) {
    const int x = static_cast<int>(i) % width, y = static_cast<int>(i) / width;
    // A pixel GD10 skipped (too few observations for its parameters) keeps the Lambertian fit
    // where there is one, whatever its region chose: it is the only fit there.
    const bool gd10_skipped = IsSkippedPixel(selection.maps, x, y), lambert_skipped = IsSkippedPixel(lambert_maps, x, y);
    if (gd10_skipped && lambert_skipped) continue;
    const bool lambertian = !lambert_skipped && (gd10_skipped || regions[region_of(i)].Lambertian());
    const double error = lambertian ? lambert_error[i] : gd10_error[i];
    if (std::isfinite(gd10_error[i]) && std::isfinite(lambert_error[i])) chosen += error;
    if (!lambertian) {
      ++selection.pixels_gd10;
      continue;
    }
    ++selection.pixels_lambert;
    SetParams(selection.maps, x, y, GetParams(lambert_maps, x, y));
    for (int c = 0; c < selection.maps.num_channels(); ++c) {  // the GD10 fit's uncertainties are not the choice's
      if (selection.maps.channel_name(c).starts_with("unc.")) selection.maps.at(c, y, x) = NAN;
    }
    selection.maps.at(lambertian_channel, y, x) = 1;
  }
  if (all_measured > 0) {
    selection.held_out_l1_gd10 = all_gd10 / all_measured;
    selection.held_out_l1_lambert = all_lambert / all_measured;
    selection.held_out_l1_chosen = chosen / all_measured;
  }
  selection.seconds = SecondsSince(start);
  return selection;
}

nlohmann::json ViewSelection::ToJson() const {
  return {{"views", views},
          {"pixels_gd10", pixels_gd10},
          {"pixels_lambert", pixels_lambert},
          {"left_out_view_l1", {{"gd10", held_out_l1_gd10}, {"lambert", held_out_l1_lambert}, {"chosen", held_out_l1_chosen}}},
          {"seconds", seconds}};
}

}  // namespace loom::fitting
