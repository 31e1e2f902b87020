#pragma once
// A capture of few views (a handful of photographs under a phone's flash) leaves a pixel's lobe
// loose: a GD10 fit can match every view it was given and predict any other one worse than a
// plain Lambertian surface does. Which of the two to keep is decided per pixel the way a user
// would judge it, by leaving views out: each view in turn is left out, both models are fitted to
// the others and scored on it (the sum of |predicted − measured| over the left-out views'
// values), and each region of one appearance (the GD10 fit's clusters; a pixel alone where it has
// none) keeps the model, fitted to every view, that predicted its pixels better: GD10 where it
// predicted them better on most of the left-out views, by more than its gain's standard error.
// Any richer model and simpler one compose so, the richer in GD10's place: method_fit.cc chooses
// the Lambertian model itself between photometric stereo's normals and the geometric normal.
//
// A view is a group of stack observations made with one camera and one set of lights: a
// photograph's colour channels.

#include <functional>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/observation_stack.h"
#include "core/status.h"

namespace loom::fitting {

// The stack's views: its observations grouped by camera (centre or view direction) and lights,
// in the order of their first observation.
std::vector<std::vector<int>> StackViews(const ObservationStack& stack);

// 1 where a pixel kept the Lambertian fit (its uncertainty channels NaN), 0 where the GD10 one.
inline constexpr const char* kLambertianChannel = "fit.lambertian";

struct ViewSelection {
  Image maps;  // per pixel the GD10 fit or the Lambertian one (fitting/model/svbrdf_maps.h), + kLambertianChannel
  int views = 0;
  int pixels_gd10 = 0;     // kept the GD10 fit
  int pixels_lambert = 0;  // kept the Lambertian one
  // Relative L1 of the left-out views over the pixels both models predicted in every fold (a
  // pixel that a fold's GD10 fit could not fit, too few views left, counts against GD10).
  double held_out_l1_gd10 = 0;     // every pixel GD10
  double held_out_l1_lambert = 0;  // every pixel Lambertian
  double held_out_l1_chosen = 0;   // each pixel its choice
  double seconds = 0;
  nlohmann::json ToJson() const;
};

// `fit` fits maps of one model to a stack (the GD10 method, or the Lambertian one); it is called
// (views + 1) times per model. Maps of both must be on the stack's grid.
using StackMapsFit = std::function<Result<Image>(const ObservationStack& stack)>;
Result<ViewSelection> SelectByLeftOutViews(const ObservationStack& stack, const StackMapsFit& gd10, const StackMapsFit& lambert);

}  // namespace loom::fitting
