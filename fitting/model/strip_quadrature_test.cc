// The strip's Gauss–Legendre quadrature: the rule itself, the strip read back from a stack's
// emitters, and a pixel's linear-light radiance against the strip as 4,096 points, nearer than
// the stack's 32 emitters.
#include "fitting/model/strip_quadrature.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/rig_observation.h"
#include "fitting/model/stack_pixels.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/testing/tac7_mini.h"
#include "sim/fabric.h"
#include "sim/stack.h"

namespace loom::fitting {
namespace {

double Percentile(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * (values.size() - 1))];
}

TEST(StripQuadratureTest, GaussLegendreIsExactForPolynomialsOfDegreeTwoNMinusOne) {
  for (int n : {1, 2, 3, 5, 10, 16}) {
    const auto rule = GaussLegendreRule(n);
    ASSERT_EQ(rule.size(), static_cast<size_t>(n));
    for (int degree = 0; degree <= 2 * n - 1; ++degree) {
      double sum = 0;
      for (const auto& [x, w] : rule) sum += w * std::pow(x, degree);
      const double exact = degree % 2 ? 0.0 : 2.0 / (degree + 1);
      EXPECT_NEAR(sum, exact, 1e-12) << n << " nodes, x^" << degree;
    }
    // and not of degree 2n: the rule is no better than it says
    double sum = 0;
    for (const auto& [x, w] : rule) sum += w * std::pow(x, 2 * n);
    if (n <= 5) {
      EXPECT_GT(std::abs(sum - 2.0 / (2 * n + 1)), 1e-4) << n << " nodes";
    }
  }
}

TEST(StripQuadratureTest, TheStripIsReadBackFromItsEmittersAndNothingElseIsAStrip) {
  const RigModel rig = testing::TacMiniGeometry();
  const LinearLightModel& light = *rig.linear_light;
  LightingState lighting;
  lighting.linear_light_on = true;
  lighting.linear_light_mm = 100;
  const auto described = DescribeRigObservation(rig, 0, lighting);
  ASSERT_TRUE(described.ok());
  const std::optional<StripSegment> strip = StripOfEmitters(described->emitters);
  ASSERT_TRUE(strip.has_value());
  EXPECT_NEAR(strip->LengthMm(), light.strip_length_mm, 1e-9);
  EXPECT_NEAR(strip->intensity_per_mm, light.intensity_per_mm, 1e-9 * light.intensity_per_mm);
  // Its centre is the emitters' mean, its direction the sweep axis.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const PointEmitter& e : described->emitters) mean += e.position_mm / described->emitters.size();
  EXPECT_LT((strip->At(0.5) - mean).norm(), 1e-9);
  EXPECT_NEAR(std::abs((strip->end_mm - strip->start_mm).normalized().dot(light.sweep_axis.normalized())), 1.0, 1e-12);

  std::vector<PointEmitter> bent = described->emitters;
  bent[5].position_mm.z() += 1;
  EXPECT_FALSE(StripOfEmitters(bent).has_value());
  std::vector<PointEmitter> uneven = described->emitters;
  uneven[7].intensity *= 1.01;
  EXPECT_FALSE(StripOfEmitters(uneven).has_value());
  EXPECT_FALSE(StripOfEmitters(std::span(described->emitters).first(1)).has_value());
}

TEST(StripQuadratureTest, BadOptionsNameEveryField) {
  StripQuadratureOptions bad;
  bad.side_nodes = 0;
  bad.lobe_nodes = 0;
  bad.lobe_fraction = 1;
  bad.moved_fraction = 0.5;
  bad.margin = -1;
  const std::string message = bad.Check().ToString();
  for (const char* field : {"side_nodes", "lobe_nodes", "lobe_fraction", "moved_fraction", "margin"}) {
    EXPECT_NE(message.find(field), std::string::npos) << field << " in " << message;
  }
  EXPECT_TRUE(StripQuadratureOptions{}.Check().ok());
  for (const auto& [nodes, side] : {std::pair{16, 3}, {20, 4}, {5, 1}, {127, 25}}) {
    const StripQuadratureOptions options = StripQuadratureWithNodes(nodes);
    EXPECT_EQ(options.Nodes(), nodes);
    EXPECT_EQ(options.side_nodes, side);
    EXPECT_TRUE(options.Check().ok()) << nodes;
  }
  StripQuadratureOptions too_many;
  too_many.side_nodes = 60;
  EXPECT_NE(too_many.Check().ToString().find("128"), std::string::npos) << too_many.Check().ToString();
}

// The fabric's linear-light observations on tac7-mini: the table with the strip as 4,096
// emitters is the reference; the stack's own 32 emitters and the quadrature's 16 nodes, placed
// around each pixel's true lobe, are compared with it, as bench_linear_light does over more
// fabrics (docs/benchmarks.md).
TEST(StripQuadratureTest, SixteenNodesAroundTheLobeAreNearerTheContinuousStripThanThe32Emitters) {
  const sim::Material fabric = sim::GenerateFabric(7, {.width_px = 12, .height_px = 12, .pixel_mm = 0.2});
  const sim::Scene scene(testing::TacMiniGeometry(), fabric);
  const ObservationStack stack = sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 24), {});
  ObservationStack continuous = stack;
  RigModel fine_rig = scene.rig();
  fine_rig.linear_light->segments = 4096;
  const std::vector<sim::Observation> plan = testing::TacMiniObservations(scene.rig(), 24);
  for (size_t k = 0; k < plan.size(); ++k) {
    if (stack.observations[k].group != ObservationGroup::kLinearLight) continue;
    LightingState lighting;
    lighting.turntable_deg = plan[k].state.turntable_deg;
    lighting.linear_light_on = true;
    lighting.linear_light_mm = plan[k].state.linear_light_mm;
    lighting.linear_light_intensity = plan[k].state.linear_light_intensity;
    const auto described = DescribeRigObservation(fine_rig, plan[k].camera, lighting);
    ASSERT_TRUE(described.ok());
    continuous.observations[k].emitters = described->emitters;
  }
  StackPixelOptions quadrature_options;
  quadrature_options.strip_quadrature = StripQuadratureOptions{};
  const StackPixels emitters(stack), nodes(stack, quadrature_options), reference(continuous);

  // Relative to the pixel's mean radiance; where the whole strip lights the pixel, and where a
  // shadow or the horizon cuts it (there both place the edge at the emitters' resolution).
  std::vector<double> emitter_error, node_error, emitter_cut_error, node_cut_error;
  for (int y = 0; y < 12; ++y) {
    for (int x = 0; x < 12; ++x) {
      const WardParams<double> truth = GetParams(fabric.maps, x, y);
      const WardLobe<double> lobe(truth);
      const std::vector<PixelObservation> exact = reference.Observations(x, y);
      const std::vector<PixelObservation> sampled = emitters.Observations(x, y);
      const std::vector<PixelObservation> integrated = nodes.Observations(x, y, truth);
      ASSERT_EQ(exact.size(), sampled.size());
      ASSERT_EQ(exact.size(), integrated.size());
      double mean = 0;
      for (const PixelObservation& o : exact) mean += PredictRadiance(lobe, o) / exact.size();
      for (size_t i = 0; i < exact.size(); ++i) {
        if (stack.observations[exact[i].source].group != ObservationGroup::kLinearLight) {
          // other observations are the emitters' whatever the option
          EXPECT_EQ(integrated[i].lights.size(), sampled[i].lights.size());
          continue;
        }
        EXPECT_LE(integrated[i].lights.size(), static_cast<size_t>(StripQuadratureOptions{}.Nodes()));
        const bool whole =
            std::all_of(exact[i].lights.begin(), exact[i].lights.end(), [](const LightSample& l) { return l.l_local.z() > 0; }) &&
            exact[i].lights.size() == 4096;
        const double truth_radiance = PredictRadiance(lobe, exact[i]);
        (whole ? emitter_error : emitter_cut_error)
            .push_back(std::abs(PredictRadiance(lobe, sampled[i]) - truth_radiance) / mean);
        (whole ? node_error : node_cut_error).push_back(std::abs(PredictRadiance(lobe, integrated[i]) - truth_radiance) / mean);
      }
    }
  }
  ASSERT_GT(node_error.size(), 12u * 12u * 24u);
  ASSERT_GT(node_cut_error.size(), 0u) << "the fabric's relief should shadow part of the strip somewhere";
  const double emitters_p99 = Percentile(emitter_error, 0.99), nodes_p99 = Percentile(node_error, 0.99);
  std::cout << "linear-light error / pixel mean, whole strip lit (" << node_error.size() << "): p99 32 emitters "
            << 100 * emitters_p99 << " %, 16 nodes " << 100 * nodes_p99 << " %; max " << 100 * Percentile(emitter_error, 1)
            << " % / " << 100 * Percentile(node_error, 1) << " %\n"
            << "strip cut by a shadow or the horizon (" << node_cut_error.size() << "): p99 "
            << 100 * Percentile(emitter_cut_error, 0.99) << " % / " << 100 * Percentile(node_cut_error, 0.99) << " %, max "
            << 100 * Percentile(emitter_cut_error, 1) << " % / " << 100 * Percentile(node_cut_error, 1) << " %\n";
  EXPECT_LT(nodes_p99, 0.5 * emitters_p99);
  EXPECT_LT(Percentile(node_error, 1), Percentile(emitter_error, 1));
  EXPECT_LT(Percentile(node_cut_error, 0.99), 1.1 * Percentile(emitter_cut_error, 0.99));
}

}  // namespace
}  // namespace loom::fitting
