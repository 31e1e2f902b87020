#include "fitting/solve/ceres_failures.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace loom::fitting {
namespace {

struct Distance {
  template <typename T>
  bool operator()(const T* x, T* residual) const {
    for (int i = 0; i < 3; ++i) residual[i] = x[i] - T(0.5);
    return true;
  }
};

// What a non-finite start did inside Ceres before loom refused such starts: the sphere
// manifold's Jacobian at NaN fails one of Ceres' checks.
void SolveFromANanPointOnTheSphere() {
  double x[3] = {std::nan(""), std::nan(""), std::nan("")};
  ceres::Problem problem;
  problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Distance, 3, 3>(new Distance), nullptr, x);
  problem.SetManifold(x, new ceres::SphereManifold<3>());
  ceres::Solver::Summary summary;
  ceres::Solve(ceres::Solver::Options(), &problem, &summary);
}

TEST(CeresFailuresDeathTest, AFailedCheckInsideCeresIsAnErrorExitWithoutABacktrace) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(
      {
        StartCeresLogging("ceres_failures_test");
        SolveFromANanPointOnTheSphere();
      },
      ::testing::ExitedWithCode(1), "Check failed.*\n.*\nerror: internal: a check inside Ceres failed");
}

}  // namespace
}  // namespace loom::fitting
