// The projector's pose from columns at the target's corners, and its focal length and centre
// from a flat board at two heights: synthetic correspondences from a projector built 3 mm and
// 0.6° away from its prior (and for the boards, with a focal length 4 % longer and its centre
// 6 px aside), with 0.05 px of decoding noise.
#include "calibration/projector.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <random>

#include "core/testing/shipped_rig.h"

namespace loom::calibration {
namespace {

ProjectorModel Knocked(const ProjectorModel& prior) {
  ProjectorModel built = prior;
  const Eigen::Matrix3d turn =
      (Eigen::AngleAxisd(DegToRad(0.6), Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(DegToRad(-0.4), Eigen::Vector3d::UnitZ()))
          .toRotationMatrix();
  const Eigen::Vector3d centre = prior.proj_from_rig.inverse().translation() + Eigen::Vector3d(2, -1.5, 1.5);
  const Eigen::Matrix3d rotation = turn * prior.proj_from_rig.rotation();
  built.proj_from_rig = MakeRigid(rotation, -rotation * centre);
  return built;
}

ProjectorModel WithOtherLens(const ProjectorModel& projector) {
  ProjectorModel built = projector;
  built.K(0, 0) *= 1.04;
  built.K(0, 2) += 6;
  return built;
}

double ColumnOf(const ProjectorModel& projector, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = projector.proj_from_rig * p;
  return projector.K(0, 0) * q.x() / q.z() + projector.K(0, 2);
}

// The target's corners at three turntable angles, as the calibration scan shows them.
std::vector<ProjectorCorrespondence> Corners(const RigModel& rig, const ProjectorModel& built, double noise_px) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, noise_px);
  const CalibrationTargetModel& target = *rig.calibration_target;
  std::vector<ProjectorCorrespondence> points;
  for (double angle : {0.0, 135.0, 270.0}) {
    for (const Eigen::Vector3d& corner : target.CornersInBoard()) {
      const Eigen::Vector3d p = rig.turntable.RigFromSample(angle) * (target.SampleFromBoard() * corner);
      points.push_back({p, ColumnOf(built, p) + noise(rng)});
    }
  }
  return points;
}

// A level-ish board at `height_mm` (slopes along x and y), 25.6 mm square like tac7-mini's white
// tile, seen by both cameras at every third pixel; every 50th ray decoded 5 columns off (the
// board's edge, a shadow).
FlatBoardView Board(const RigModel& rig, const ProjectorModel& built, const std::string& name, double nominal_mm,
                    double height_mm, Eigen::Vector2d slope, double noise_px, int stride = 3, double half_mm = 12.8) {
  std::mt19937 rng(static_cast<unsigned>(height_mm * 100));
  std::normal_distribution<double> noise(0, noise_px);
  FlatBoardView board{name, nominal_mm, {}};
  for (int c = 0; c < static_cast<int>(rig.cameras.size()); ++c) {
    const CameraModel& camera = rig.cameras[c];
    const Rigid3d rig_from_cam = camera.cam_from_rig.inverse();
    for (int y = 0; y < camera.height; y += stride) {
      for (int x = 0; x < camera.width; x += stride) {
        FlatBoardRay ray{c, rig_from_cam.translation(), rig_from_cam.rotation() * camera.Unproject({x, y}), 0};
        const double t = (height_mm + slope.dot(ray.origin_mm.head<2>()) - ray.origin_mm.z()) /
                         (ray.direction.z() - slope.dot(ray.direction.head<2>()));
        const Eigen::Vector3d point = ray.origin_mm + t * ray.direction;
        if (std::abs(point.x()) > half_mm || std::abs(point.y()) > half_mm) continue;
        ray.column = ColumnOf(built, point) + noise(rng) + (board.rays.size() % 50 == 49 ? 5 : 0);
        board.rays.push_back(ray);
      }
    }
  }
  return board;
}

// The largest column error of `found` against `built` over the sample volume (±half_mm) up to `top_mm`.
double WorstColumn(const ProjectorModel& found, const ProjectorModel& built, double top_mm, double half_mm = 12) {
  double worst = 0;
  for (double x : {-half_mm, 0.0, half_mm}) {
    for (double y : {-half_mm, 0.0, half_mm}) {
      for (double z : {-2.0, 0.0, 5.0, top_mm}) {
        worst = std::max(worst, std::abs(ColumnOf(found, {x, y, z}) - ColumnOf(built, {x, y, z})));
      }
    }
  }
  return worst;
}

void PrintBoards(const ProjectorCalibration& found) {
  std::cout << "focal " << found.focal_change_percent << " % (1σ " << found.focal_sigma_percent << " %), cx "
            << found.cx_change_px << " px (1σ " << found.cx_sigma_px << " px); boards at " << found.boards[0].height_mm << " and "
            << found.boards[1].height_mm << " mm, tilts " << found.boards[0].tilt_deg << ", " << found.boards[1].tilt_deg
            << " deg, " << found.boards[0].rays << " and " << found.boards[1].rays << " rays kept, RMS "
            << found.boards[0].rms_columns << ", " << found.boards[1].rms_columns << "\n";
}

// tac7's cameras see 150 mm of the projector's 210 mm wide field at the sample: enough.
TEST(ProjectorTest, FindsTheFocalLengthAndCentreFromABoardAtTwoHeights) {
  RigModel rig = loom::testing::ShippedRigModel("tac7");
  // The numbers below were measured with tac7-mini's target (tac7.yaml's own came later).
  rig.calibration_target = loom::testing::ShippedRigModel("tac7-mini").calibration_target;
  const ProjectorModel built = WithOtherLens(Knocked(*rig.projector));
  const ProjectorObservations observed{Corners(rig, built, 0.05),
                                       {Board(rig, built, "white tile", 0, 0.2, {0.003, -0.002}, 0.05, 24, 63),
                                        Board(rig, built, "white tile on its spacer", 30, 30.4, {-0.002, 0.004}, 0.05, 24, 63)}};
  const Result<ProjectorCalibration> found = CalibrateProjector(*rig.projector, observed);
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  ASSERT_EQ(found->boards.size(), 2u);
  PrintBoards(*found);
  // Measured: 4.002 % (1σ 0.009 %), 6.11 px (1σ 0.17 px); heights 0.200 and 30.400 mm.
  EXPECT_TRUE(found->intrinsics_fitted);
  EXPECT_NEAR(found->focal_change_percent, 4, 0.05);
  EXPECT_NEAR(found->cx_change_px, 6, 0.5);
  EXPECT_NEAR(found->boards[0].height_mm, 0.2, 0.02);
  EXPECT_NEAR(found->boards[1].height_mm, 30.4, 0.02);
  EXPECT_NEAR(found->boards[1].tilt_deg, RadToDeg(std::atan(std::hypot(0.002, 0.004))), 0.02);
  EXPECT_LT(found->boards[1].rms_columns, 0.06);  // the outliers dropped
  EXPECT_LT(WorstColumn(found->projector, built, 30, 60), 0.1);
}

// tac7-mini's cameras see only 32 mm: focal length still trades against distance, so fx and cx
// stay at the prior's; the boards still fit the pose to the columns up to the spacer's height.
TEST(ProjectorTest, HoldsTheFocalLengthWhereTheBoardsCoverTooLittleOfTheField) {
  const RigModel rig = loom::testing::ShippedRigModel("tac7-mini");
  const ProjectorModel built = WithOtherLens(Knocked(*rig.projector));
  ProjectorObservations observed{Corners(rig, built, 0.05), {}};
  const Result<ProjectorCalibration> corners_only = CalibrateProjector(*rig.projector, observed);
  ASSERT_TRUE(corners_only.ok()) << corners_only.status().ToString();
  observed.boards = {Board(rig, built, "white tile", 0, 0.2, {0.003, -0.002}, 0.05),
                     Board(rig, built, "white tile on its spacer", 30, 30.4, {-0.002, 0.004}, 0.05)};
  const Result<ProjectorCalibration> found = CalibrateProjector(*rig.projector, observed);
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  ASSERT_EQ(found->boards.size(), 2u);
  PrintBoards(*found);
  EXPECT_FALSE(found->intrinsics_fitted);
  EXPECT_EQ(found->projector.K, rig.projector->K);
  EXPECT_GT(found->focal_sigma_percent, 0.1);
  EXPECT_NEAR(found->boards[1].height_mm, 30.4, 0.05);
  const double worst_corners_only = WorstColumn(corners_only->projector, built, 30);
  const double worst_found = WorstColumn(found->projector, built, 30);
  std::cout << "columns up to 30 mm: corners alone off by up to " << worst_corners_only << " px, with the boards " << worst_found
            << " px\n";
  EXPECT_LT(worst_found, worst_corners_only);
  EXPECT_LT(worst_found, 0.05);
}

// The operator left the spacer out: both boards lie on the table, nothing separates focal length
// from distance, and the lens stays the prior's.
TEST(ProjectorTest, ASpacerLeftOutHoldsTheLens) {
  RigModel rig = loom::testing::ShippedRigModel("tac7");
  rig.calibration_target = loom::testing::ShippedRigModel("tac7-mini").calibration_target;
  const ProjectorModel built = WithOtherLens(Knocked(*rig.projector));
  const ProjectorObservations observed{Corners(rig, built, 0.05),
                                       {Board(rig, built, "white tile", 0, 0.2, {0, 0}, 0.05, 24, 63),
                                        Board(rig, built, "white tile on its spacer", 30, 0.3, {0, 0}, 0.05, 24, 63)}};
  const Result<ProjectorCalibration> found = CalibrateProjector(*rig.projector, observed);
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  PrintBoards(*found);
  EXPECT_FALSE(found->intrinsics_fitted);
  EXPECT_GT(found->focal_sigma_percent, 0.1);
  EXPECT_EQ(found->projector.K, rig.projector->K);
  EXPECT_NEAR(found->boards[1].height_mm, 0.3, 0.05);
}

TEST(ProjectorTest, BoardsThatCannotSeparateFocalLengthAreAnErrorNamingThem) {
  const RigModel rig = loom::testing::ShippedRigModel("tac7-mini");
  const ProjectorModel built = WithOtherLens(Knocked(*rig.projector));
  ProjectorObservations observed{
      Corners(rig, built, 0.05),
      {Board(rig, built, "white tile", 0, 0, {0, 0}, 0.05), Board(rig, built, "white tile on its spacer", 2, 2, {0, 0}, 0.05)}};
  const Result<ProjectorCalibration> too_close = CalibrateProjector(*rig.projector, observed);
  ASSERT_FALSE(too_close.ok());
  EXPECT_NE(too_close.status().ToString().find("span 2 mm"), std::string::npos) << too_close.status().ToString();
  observed.boards[1] = Board(rig, built, "white tile on its spacer", 30, 30, {0, 0}, 0.05);
  std::erase_if(observed.boards[1].rays, [](const FlatBoardRay& ray) { return ray.camera == 1; });
  const Result<ProjectorCalibration> one_camera = CalibrateProjector(*rig.projector, observed);
  ASSERT_FALSE(one_camera.ok());
  EXPECT_NE(one_camera.status().ToString().find("white tile on its spacer"), std::string::npos) << one_camera.status().ToString();
}

TEST(ProjectorTest, FindsTheProjectorsColumnsAsBuilt) {
  const RigModel rig = loom::testing::ShippedRigModel("tac7-mini");
  ASSERT_TRUE(rig.projector && rig.calibration_target);
  const ProjectorModel built = Knocked(*rig.projector);
  const Result<ProjectorCalibration> found = CalibrateProjector(*rig.projector, {Corners(rig, built, 0.05), {}});
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  EXPECT_EQ(found->correspondences, 3 * 35);
  EXPECT_LT(found->rms_columns, 0.1);
  EXPECT_GT(found->column_change_px, 1.0);
  // What structured light uses: the column of every point of the sample volume.
  double worst_found = 0, worst_prior = 0;
  for (double x : {-12.0, 0.0, 12.0}) {
    for (double y : {-12.0, 0.0, 12.0}) {
      for (double z : {-2.0, 0.0, 5.0}) {
        const Eigen::Vector3d p(x, y, z);
        worst_found = std::max(worst_found, std::abs(ColumnOf(found->projector, p) - ColumnOf(built, p)));
        worst_prior = std::max(worst_prior, std::abs(ColumnOf(*rig.projector, p) - ColumnOf(built, p)));
      }
    }
  }
  std::cout << "columns in the sample volume: prior off by up to " << worst_prior << " px, calibrated " << worst_found << " px\n";
  // Measured: the prior off by up to 2.0 px, the calibration 0.063 px.
  EXPECT_GT(worst_prior, 1.5);
  EXPECT_LT(worst_found, 0.1);
}

TEST(ProjectorTest, FilesRoundTripAndTooFewCornersAreAnError) {
  const RigModel rig = loom::testing::ShippedRigModel("tac7-mini");
  const std::vector<ProjectorCorrespondence> points = Corners(rig, Knocked(*rig.projector), 0.05);
  EXPECT_FALSE(CalibrateProjector(*rig.projector, {{points.begin(), points.begin() + 5}, {}}).ok());
  const Result<ProjectorCalibration> found = CalibrateProjector(*rig.projector, {points, {}});
  ASSERT_TRUE(found.ok()) << found.status().ToString();
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / ("projector_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  ProjectorCalibration fitted = *found;  // as if boards had fitted the lens
  fitted.projector.K(0, 0) *= 1.04;
  fitted.projector.K(0, 2) += 6;
  fitted.intrinsics_fitted = true;
  ASSERT_TRUE(WriteProjectorCalibration(dir, fitted, "scan/").ok());
  RigModel applied = rig;
  const Result<bool> done = ApplyProjectorCalibration(dir, &applied);
  ASSERT_TRUE(done.ok()) << done.status().ToString();
  EXPECT_TRUE(*done);
  EXPECT_TRUE(applied.projector->proj_from_rig.isApprox(fitted.projector.proj_from_rig, 1e-12));
  EXPECT_TRUE(applied.projector->K.isApprox(fitted.projector.K, 1e-12));
  RigModel other = rig;
  other.projector->width = 640;
  const Result<bool> wrong = ApplyProjectorCalibration(dir, &other);
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.status().subject().find("projector.yaml"), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace loom::calibration
