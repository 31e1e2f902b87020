// The choice between the GD10 fit and the Lambertian one by left-out views (view_selection.h), on
// a few views of a small tac7-mini fabric. The two "fits" here return fixed maps, so that what
// each model predicts of a left-out view is known: the truth for one, a worse material for the
// other.
#include "fitting/view_selection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "fitting/model/svbrdf_maps.h"
#include "fitting/solve/stack_fitter.h"
#include "fitting/testing/tac7_mini.h"
#include "sim/fabric.h"
#include "sim/stack.h"

namespace loom::fitting {
namespace {

struct FewViews {
  ObservationStack stack;
  Image truth;
};

FewViews SixViewsOfAFabric() {
  const sim::Scene scene(testing::TacMiniGeometry(), sim::GenerateFabric(4, {.width_px = 6, .height_px = 6, .pixel_mm = 0.2}));
  const ObservationStack all = sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 4), {});
  const std::vector<std::vector<int>> views = StackViews(all);
  std::vector<int> kept;
  for (size_t v = 0; v < 6; ++v) kept.insert(kept.end(), views[v].begin(), views[v].end());
  return {SelectObservations(all, kept), sim::TruthOnStackGrid(scene, {}).maps};
}

// A pixel a fit skipped: NaN in every parameter (svbrdf_maps.h).
WardParams<double> Skipped() {
  WardParams<double> p;
  p.n_s = p.a_d = p.a_s = Eigen::Vector3d::Constant(NAN);
  p.sigma_x = p.sigma_y = p.alpha = p.f0 = NAN;
  return p;
}

// One appearance region (fit.cluster 0) over every pixel, as the GD10 fit labels its clusters.
Image OneRegion(Image maps) {
  const int cluster = maps.AddChannel(kFitClusterChannel);
  for (float& label : maps.channel(cluster)) label = 0;
  return maps;
}

Image WithDiffuseScaled(Image maps, float factor) {
  for (const char* name : {"a_d.R", "a_d.G", "a_d.B"}) {
    for (float& value : maps.channel(*maps.FindChannel(name))) value *= factor;
  }
  return maps;
}

// A fit that cannot fit one pixel of a region (too few views left in some fold) loses that pixel,
// not the region's choice: the region keeps the model that predicted its views better.
TEST(ViewSelectionTest, AModelThatSkipsAPixelInSomeFoldsStillWinsTheRegionItPredictsBetter) {
  const FewViews capture = SixViewsOfAFabric();
  const size_t all_observations = capture.stack.observations.size();
  const StackMapsFit gd10 = [&](const ObservationStack&) -> Result<Image> {
    return OneRegion(WithDiffuseScaled(capture.truth, 1.5f));
  };
  const StackMapsFit lambert = [&](const ObservationStack& stack) -> Result<Image> {
    Image maps = capture.truth;
    if (stack.observations.size() < all_observations) SetParams(maps, 0, 0, Skipped());
    return maps;
  };
  const Result<ViewSelection> selection = SelectByLeftOutViews(capture.stack, gd10, lambert);
  ASSERT_TRUE(selection.ok()) << selection.status().ToString();
  EXPECT_EQ(selection->views, 6);
  EXPECT_EQ(selection->pixels_lambert, 36);
  EXPECT_EQ(selection->pixels_gd10, 0);
  EXPECT_LT(selection->held_out_l1_chosen, selection->held_out_l1_gd10);
  EXPECT_EQ(GetParams(selection->maps, 0, 0).a_d, GetParams(capture.truth, 0, 0).a_d);
}

// A model that no fold could fit (too few views left for GD10's parameters) is not chosen for
// the other's errors, however large: it predicted nothing to compare.
TEST(ViewSelectionTest, AModelNoFoldCouldFitIsNotChosenOverOneThatPredictedBadly) {
  const FewViews capture = SixViewsOfAFabric();
  const size_t all_observations = capture.stack.observations.size();
  const StackMapsFit gd10 = [&](const ObservationStack& stack) -> Result<Image> {
    Image maps = OneRegion(capture.truth);
    if (stack.observations.size() == all_observations) return maps;
    for (int y = 0; y < maps.height(); ++y) {
      for (int x = 0; x < maps.width(); ++x) SetParams(maps, x, y, Skipped());
    }
    return maps;
  };
  const StackMapsFit lambert = [&](const ObservationStack&) -> Result<Image> { return WithDiffuseScaled(capture.truth, 4.0f); };
  const Result<ViewSelection> selection = SelectByLeftOutViews(capture.stack, gd10, lambert);
  ASSERT_TRUE(selection.ok()) << selection.status().ToString();
  EXPECT_EQ(selection->pixels_lambert, 36);
}

// Where the other model wins, a pixel the full fit of the losing model skipped is not an error.
TEST(ViewSelectionTest, TheRegionKeepsTheGd10FitWhereItPredictsTheLeftOutViewsBetter) {
  const FewViews capture = SixViewsOfAFabric();
  const StackMapsFit gd10 = [&](const ObservationStack&) -> Result<Image> { return OneRegion(capture.truth); };
  const StackMapsFit lambert = [&](const ObservationStack&) -> Result<Image> {
    Image maps = WithDiffuseScaled(capture.truth, 0.5f);
    SetParams(maps, 1, 1, Skipped());
    return maps;
  };
  const Result<ViewSelection> selection = SelectByLeftOutViews(capture.stack, gd10, lambert);
  ASSERT_TRUE(selection.ok()) << selection.status().ToString();
  EXPECT_EQ(selection->pixels_gd10, 36);
  EXPECT_EQ(selection->pixels_lambert, 0);
  EXPECT_LT(selection->held_out_l1_chosen, selection->held_out_l1_lambert);
}

// A pixel GD10 cannot fit at all (too few observations for its parameters) keeps the Lambertian
// fit even where its region keeps GD10: it is the only fit there.
TEST(ViewSelectionTest, APixelGd10SkipsKeepsTheLambertianFit) {
  const FewViews capture = SixViewsOfAFabric();
  const StackMapsFit gd10 = [&](const ObservationStack&) -> Result<Image> {
    Image maps = OneRegion(capture.truth);
    SetParams(maps, 0, 0, Skipped());
    return maps;
  };
  const Image lambert_maps = WithDiffuseScaled(capture.truth, 0.5f);
  const StackMapsFit lambert = [&](const ObservationStack&) -> Result<Image> { return lambert_maps; };
  const Result<ViewSelection> selection = SelectByLeftOutViews(capture.stack, gd10, lambert);
  ASSERT_TRUE(selection.ok()) << selection.status().ToString();
  EXPECT_EQ(selection->pixels_gd10, 35);
  EXPECT_EQ(selection->pixels_lambert, 1);
  EXPECT_EQ(GetParams(selection->maps, 0, 0).a_d, GetParams(lambert_maps, 0, 0).a_d);
  EXPECT_EQ(GetParams(selection->maps, 1, 0).a_d, GetParams(capture.truth, 1, 0).a_d);
}

// Whether `stack` lacks view `view` of `all` (StackViews' numbering): none of its observations
// has that view's camera and first light.
bool LeavesOut(const ObservationStack& stack, const ObservationStack& all, int view) {
  const StackObservation& first = all.observations[StackViews(all)[view].front()];
  return std::none_of(stack.observations.begin(), stack.observations.end(), [&](const StackObservation& o) {
    return o.camera_mm == first.camera_mm && o.emitters.front().position_mm == first.emitters.front().position_mm;
  });
}

// GD10 predicts the region far better on two left-out views and a little worse on the four
// others, better in all and by more than its gain's standard error: the region keeps the
// Lambertian fit, which predicted most views better.
TEST(ViewSelectionTest, Gd10IsNotKeptWhereAFewViewsWinItTheSumButItPredictsMostViewsWorse) {
  const FewViews capture = SixViewsOfAFabric();
  const StackMapsFit gd10 = [&](const ObservationStack&) -> Result<Image> {
    return OneRegion(WithDiffuseScaled(capture.truth, 1.1f));
  };
  const StackMapsFit lambert = [&](const ObservationStack& stack) -> Result<Image> {
    const bool badly = LeavesOut(stack, capture.stack, 0) || LeavesOut(stack, capture.stack, 1);
    return WithDiffuseScaled(capture.truth, badly ? 3.0f : 1.05f);
  };
  const Result<ViewSelection> selection = SelectByLeftOutViews(capture.stack, gd10, lambert);
  ASSERT_TRUE(selection.ok()) << selection.status().ToString();
  ASSERT_LT(selection->held_out_l1_gd10, selection->held_out_l1_lambert);
  EXPECT_EQ(selection->pixels_lambert, 36);
  EXPECT_EQ(selection->pixels_gd10, 0);
}

// GD10 predicts the region a little better on five left-out views and much worse on the sixth,
// better in all and on most views, but by less than its gain's spread over the views: the region
// keeps the Lambertian fit (an unseen view may as well be one that GD10 predicts much worse).
TEST(ViewSelectionTest, Gd10IsNotKeptWhereItsGainIsSmallAgainstItsSpreadOverTheViews) {
  const FewViews capture = SixViewsOfAFabric();
  const StackMapsFit gd10 = [&](const ObservationStack& stack) -> Result<Image> {
    return OneRegion(WithDiffuseScaled(capture.truth, LeavesOut(stack, capture.stack, 0) ? 1.5f : 1.1f));
  };
  const StackMapsFit lambert = [&](const ObservationStack&) -> Result<Image> { return WithDiffuseScaled(capture.truth, 1.2f); };
  const Result<ViewSelection> selection = SelectByLeftOutViews(capture.stack, gd10, lambert);
  ASSERT_TRUE(selection.ok()) << selection.status().ToString();
  ASSERT_LT(selection->held_out_l1_gd10, selection->held_out_l1_lambert);
  EXPECT_EQ(selection->pixels_lambert, 36);
  EXPECT_EQ(selection->pixels_gd10, 0);
}

}  // namespace
}  // namespace loom::fitting
