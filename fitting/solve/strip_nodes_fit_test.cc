// The stack fitter with the linear light's strips integrated by nodes placed around each pixel's
// lobe (fitting/model/strip_quadrature.h) instead of the stack's emitters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "fitting/model/strip_quadrature.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/solve/stack_fitter.h"
#include "fitting/testing/tac7_mini.h"
#include "sim/fabric.h"
#include "sim/stack.h"

namespace loom::fitting {
namespace {

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return std::nan("");
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * (values.size() - 1))];
}

// The stack fitter's first fits with the strips as nodes around each pixel's start: a pixel whose
// lobe leaves the span its nodes were placed for is fitted again with nodes placed where it
// ended; the normals end as near the truth as the emitters' fits, and where both find it, σ ends
// where the emitters' does. (From these far starts the emitters' fits find more true normals,
// 39–40 of 64 within 0.5° against the nodes' 35–36, by CPU, since the refiner's retreat after a
// rejected step: the nodes are placed for the start's lobe, so a path far from it follows a
// coarser integral.)
TEST(StripNodesFitTest, TheRefinerFitsWithNodesAndPlacesThemAgainWhereALobeMoved) {
  const sim::Material fabric = sim::GenerateFabric(5, {.width_px = 8, .height_px = 8, .pixel_mm = 0.2});
  const sim::Scene scene(testing::TacMiniGeometry(), fabric);
  const ObservationStack stack = sim::RenderStack(scene, testing::TacMiniObservations(scene.rig(), 24), {});
  // Starts 8° off in the normal and 40 % wide in σ: far enough for some lobes to move out.
  Image initial = fabric.maps;
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      WardParams<double> p = GetParams(fabric.maps, x, y);
      p.n_s = (p.n_s + Eigen::Vector3d(0.14 * ((x + y) % 2 ? 1 : -1), 0, 0)).normalized();
      p.sigma_x *= 1.4;
      p.sigma_y *= 1.4;
      SetParams(initial, x, y, p);
    }
  }
  StackFitOptions options;
  options.initial_maps = &initial;
  options.solver = PixelSolver::kBatchRefiner;
  options.retry_poor_fits = false;
  // 24 observations space their half-vectors widely enough to raise the σ floor
  // (StackFitOptions::min_sigma); this compares two integrals of the strip, not the floor.
  options.min_sigma = kMinSigma;
  const Result<StackFit> with_emitters = FitStack(stack, options);
  options.pixels.strip_quadrature = StripQuadratureOptions{};
  const Result<StackFit> with_nodes = FitStack(stack, options);
  ASSERT_TRUE(with_emitters.ok() && with_nodes.ok());
  EXPECT_EQ(with_emitters->summary.pixels_nodes_replaced, 0);
  EXPECT_GT(with_nodes->summary.pixels_nodes_replaced, 0);
  EXPECT_EQ(with_nodes->summary.ToJson()["pixels_nodes_replaced"], with_nodes->summary.pixels_nodes_replaced);
  std::vector<double> normal_deg, emitters_normal_deg, sigma_change, both_normal_deg, both_emitters_normal_deg;
  const auto angle_deg = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180 / M_PI;
  };
  for (int y = 0; y < 8; ++y) {
    for (int x = 0; x < 8; ++x) {
      const WardParams<double> truth = GetParams(fabric.maps, x, y);
      const WardParams<double> nodes = GetParams(with_nodes->maps, x, y), emitters = GetParams(with_emitters->maps, x, y);
      normal_deg.push_back(angle_deg(truth.n_s, nodes.n_s));
      emitters_normal_deg.push_back(angle_deg(truth.n_s, emitters.n_s));
      // σ compared only where both fits found the true normal: from starts this far off, either
      // ends in a wrong basin for a third of the pixels, and which pixels differs with the path.
      if (normal_deg.back() < 0.5 && emitters_normal_deg.back() < 0.5) {
        sigma_change.push_back(std::abs(nodes.sigma_x - emitters.sigma_x) / emitters.sigma_x);
        both_normal_deg.push_back(normal_deg.back());
        both_emitters_normal_deg.push_back(emitters_normal_deg.back());
      }
    }
  }
  std::cout << "normal error median / p90: with nodes " << Percentile(normal_deg, 0.5) << "° / " << Percentile(normal_deg, 0.9)
            << "°, with the emitters " << Percentile(emitters_normal_deg, 0.5) << "° / " << Percentile(emitters_normal_deg, 0.9)
            << "°; within 0.5° " << std::count_if(normal_deg.begin(), normal_deg.end(), [](double d) { return d < 0.5; }) << " / "
            << std::count_if(emitters_normal_deg.begin(), emitters_normal_deg.end(), [](double d) { return d < 0.5; })
            << ", both at " << sigma_change.size() << " pixels (normal median there " << Percentile(both_normal_deg, 0.5)
            << "° / " << Percentile(both_emitters_normal_deg, 0.5) << "°), σx nodes / emitters there median "
            << 100 * Percentile(sigma_change, 0.5) << " %; " << with_nodes->summary.pixels_nodes_replaced
            << " pixels' nodes placed again\n";
  const auto found = [](const std::vector<double>& deg) {
    return std::count_if(deg.begin(), deg.end(), [](double d) { return d < 0.5; });
  };
  // Counted, not a median over all 64: with a third of the pixels in wrong basins the median
  // lies at the edge of the found ones, and moved by 0.1° between CPUs' kernels. The nodes find
  // 4 fewer on the CPUs measured.
  EXPECT_GE(found(normal_deg), found(emitters_normal_deg) - 6);
  EXPECT_LT(Percentile(normal_deg, 0.9), Percentile(emitters_normal_deg, 0.9) + 0.5);
  ASSERT_GE(sigma_change.size(), 16u);
  EXPECT_LT(Percentile(both_normal_deg, 0.5), Percentile(both_emitters_normal_deg, 0.5) + 0.1);
  EXPECT_LT(Percentile(sigma_change, 0.5), 0.01);
}

}  // namespace
}  // namespace loom::fitting
