#pragma once
// Robust photometric stereo: each pixel as a Lambertian surface, a normal and an RGB albedo,
// fitted by least squares to its observations (Woodham's method), with shadows and highlights
// left out by a stated rule. `loom fit --method lambert`: the baseline every report shows, and the
// per-pixel start of the GD10 fits (stack_fitter.h).
//
// The model: L_o = (w_o · a)/π · (n · E_o), E_o = Σ_j E_j l_j the observation's light samples
// summed as one irradiance vector (exact while every sample lights the pixel's side). With the
// RGB albedo a = ρ |a| (ρ its chromaticity) this is linear in g = |a| n for a fixed ρ, and linear
// in a for a fixed n, so the fit alternates: g by least squares (the normal and the albedo's
// size), then a by non-negative least squares at that normal (a camera that records only grey
// leaves the albedo's colour undetermined: it is held grey).
//
// The rule that leaves observations out:
//  1. the first fit takes the observations whose shading ratio L_o / ((w_o·ρ)|E_o|) lies
//     between the `trim_dark` and `trim_bright` quantiles of the pixel's (cast and attached
//     shadows are the darkest, highlights the brightest), ρ each colour's median of L_o /
//     ((w_o·1)|E_o|) over the pixel's observations of that colour;
//  2. then, `rounds` times: every observation whose light lies at least `min_cos_light` above
//     the fitted surface (n · Ê_o) and whose residual is within `reject_sigmas` robust standard
//     deviations (1.4826 × the median absolute residual of those kept) is kept, and the pixel
//     fitted again on those.
// A pixel with fewer than `min_observations` kept is not fitted.

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/observation_stack.h"
#include "core/status.h"
#include "fitting/solve/pixel_fitter.h"

namespace loom::fitting {

struct LambertFitOptions {
  double trim_dark = 0.25;     // quantile of the shading ratio below which the first fit leaves an observation out
  double trim_bright = 0.75;   // and above which (a highlight)
  double min_cos_light = 0.1;  // cosine of the light's angle off the fitted normal below which it is left out
  double reject_sigmas = 2.5;  // residuals beyond this many robust standard deviations are left out
  int rounds = 3;              // refits after the first
  int min_observations = 3;    // kept observations a pixel needs (3: a normal and an albedo's size)
  // False: the normal is held at the geometric one and only the albedo is fitted (the plainest
  // baseline: a Lambertian surface with one albedo per pixel).
  bool fit_normal = true;
  // True: a pixel whose normal the rule cannot fit (too few observations kept, or lights too
  // nearly parallel to find a normal facing the camera) gets the albedo under the geometric normal
  // instead of no fit, so that a choice of the Lambertian model holds on every pixel
  // (fitting/view_selection.h).
  bool geometric_normal_fallback = false;
  int threads = 0;       // 0: one per core
  Status Check() const;  // every problem, naming the field
};

struct LambertPixel {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, the pixel's local frame
  Eigen::Vector3d albedo = Eigen::Vector3d::Zero();   // RGB, not bounded
  bool normal_fitted = true;                          // false: held at the geometric normal (geometric_normal_fallback)
  int observations_used = 0;
  double rms = 0;  // of the kept observations' residuals, relative to their mean radiance
  // The same surface as GD10 maps it (a_s 0) on every observation, as stack_fitter.cc's retries
  // measure a fit: a GD10 fit worse than this is in a wrong basin, since GD10 holds it.
  double rms_all = 0;
};

// A Lambertian pixel as GD10 parameters: its normal and albedo (clamped to kMaxAlbedo), a_s 0,
// σ 0.2 (the lobe absent: any width), F0 1.
WardParams<double> AsWardParams(const LambertPixel& pixel);

// One pixel's fit; nothing where fewer than options.min_observations are kept (and, with
// options.geometric_normal_fallback, nothing only where the albedo-only fit keeps too few).
std::optional<LambertPixel> FitLambertPixel(const std::vector<PixelObservation>& observations, const LambertFitOptions& options);

// Every pixel of the stack (threaded): maps in stack_fitter.h's layout with the shading normal,
// the albedo clamped to [0, kMaxAlbedo] (counted), no specular (a_s 0, σ 1, α 0, F0 1), NaN
// where a pixel is not fitted; fit.observations and fit.rms as the other methods write them.
struct LambertFit {
  Image maps;
  int pixels = 0;
  int pixels_fitted = 0;
  int pixels_at_albedo_bound = 0;  // an albedo above kMaxAlbedo, clamped: the images' scale is off
  double seconds = 0;
  nlohmann::json ToJson() const;
};
Result<LambertFit> FitLambert(const ObservationStack& stack, const LambertFitOptions& options = {});

// The same per pixel, before any map is written: the GD10 fits start from these (nothing where
// a pixel is not fitted).
std::vector<std::optional<LambertPixel>> LambertPixels(const ObservationStack& stack, const LambertFitOptions& options);

}  // namespace loom::fitting
