#include "acquisition/crop_windows.h"
#include "core/testing/build_tree.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "core/geometry.h"
#include "core/rig_file.h"

namespace loom::acquisition {
namespace {

RigModel Rig(const std::string& name) {
  const Result<RigModel> rig = LoadRigModel(loom::testing::SourceDir() + "/configs/rig/" + name + ".yaml");
  EXPECT_TRUE(rig.ok()) << rig.status().ToString();
  return rig.ok() ? *rig : RigModel{};
}

bool Inside(const scan::Roi& window, const Eigen::Vector2d& pixel) {
  return pixel.x() >= window.x && pixel.y() >= window.y && pixel.x() < window.x + window.width &&
         pixel.y() < window.y + window.height;
}

// Every camera's window holds the crop's corners at every turntable angle, on the holder and on
// top of the relief, and is a small part of tac7's 2048 × 1536 sensors for a 64-pixel crop.
TEST(CropWindowsTest, EachCamerasWindowSeesTheCropAtEveryAngle) {
  const RigModel rig = Rig("tac7");
  const CropOptions options{.size_mm = 12.8};
  const Result<std::map<std::string, scan::Roi>> windows = CropWindows(rig, options);
  ASSERT_TRUE(windows.ok()) << windows.status().ToString();
  ASSERT_EQ(windows->size(), rig.cameras.size());
  for (const CameraModel& camera : rig.cameras) {
    const scan::Roi& window = windows->at(camera.name);
    EXPECT_EQ(window.x % 8, 0) << camera.name;
    EXPECT_EQ(window.y % 8, 0) << camera.name;
    EXPECT_LT(window.width * window.height, camera.width * camera.height / 4) << camera.name;
    for (double angle = 0; angle < 360; angle += 7.5) {
      for (const Eigen::Vector3d& corner :
           {Eigen::Vector3d(6.4, 6.4, 0), Eigen::Vector3d(-6.4, 6.4, 3), Eigen::Vector3d(6.4, -6.4, 1.5)}) {
        Eigen::Vector2d pixel;
        ASSERT_TRUE(camera.Project(camera.cam_from_rig * (rig.turntable.RigFromSample(angle) * corner), &pixel));
        EXPECT_TRUE(Inside(window, pixel)) << camera.name << " at " << angle << "°: " << pixel.transpose();
      }
    }
  }
  // A crop as large as the sample holder: clipped to the sensor.
  const Result<std::map<std::string, scan::Roi>> whole = CropWindows(rig, {.size_mm = 1000});
  ASSERT_TRUE(whole.ok()) << whole.status().ToString();
  for (const CameraModel& camera : rig.cameras) {
    const scan::Roi& window = whole->at(camera.name);
    EXPECT_EQ(window.x, 0);
    EXPECT_EQ(window.width, camera.width);
  }
}

TEST(CropWindowsTest, BadOptionsAreNamed) {
  const RigModel rig = Rig("tac7-mini");
  const Result<std::map<std::string, scan::Roi>> bad =
      CropWindows(rig, {.size_mm = -1, .relief_mm = NAN, .margin_px = -2, .alignment_px = 0});
  ASSERT_FALSE(bad.ok());
  for (const char* field : {"size_mm", "relief_mm", "margin_px", "alignment_px"}) {
    EXPECT_NE(bad.status().ToString().find(field), std::string::npos) << bad.status().ToString();
  }
}

// A tac7 calibration scan read through windows: the target's, the sphere's and the chart's steps
// hold every camera's view of their object at the step's angle in a window of a quarter of the
// sensor on average; the white tile's and the dark steps read whole frames.
TEST(ObjectWindowsTest, EachCalibrationObjectIsInsideItsStepsWindows) {
  const RigModel rig = Rig("tac7");
  const Result<scan::Preset> preset = scan::LoadPreset(loom::testing::SourceDir() + "/configs/plans/low.yaml");
  ASSERT_TRUE(preset.ok()) << preset.status().ToString();
  const Result<scan::Plan> plan = WithObjectWindows(*scan::MakeCalibrationPlan(rig, *preset), rig, {});
  ASSERT_TRUE(plan.ok()) << plan.status().ToString();
  const CalibrationTargetModel& target = *rig.calibration_target;
  const double r = rig.light_probe->radius_mm;
  std::map<scan::ScanObject, int> windowed;
  double read_fraction = 0;  // summed over the windows
  int windows = 0;
  for (const scan::Step& step : plan->steps) {
    std::vector<Eigen::Vector3d> object;  // points of the object that the window must hold (sample frame)
    if (step.object == scan::ScanObject::kTarget) {
      for (const Eigen::Vector3d& corner : target.CornersInBoard()) object.push_back(target.SampleFromBoard() * corner);
    } else if (step.object == scan::ScanObject::kChromeSphere) {
      object = {{r, 0, r}, {-r, 0, r}, {0, r, r}, {0, -r, r}, {0, 0, 2 * r}};
    } else if (step.object == scan::ScanObject::kColourChart) {
      for (int patch = 0; patch < ColourChartModel::kPatches; ++patch) {
        object.emplace_back(rig.colour_chart.PatchCentre(patch).x(), rig.colour_chart.PatchCentre(patch).y(), 0);
      }
    }
    if (object.empty()) {
      EXPECT_TRUE(step.windows.empty()) << "step " << step.index;
      continue;
    }
    ASSERT_EQ(step.windows.size(), step.cameras.size()) << "step " << step.index;
    ++windowed[step.object];
    for (const std::string& name : step.cameras) {
      const CameraModel& camera = *rig.FindCamera(name);
      const scan::Roi& window = step.windows.at(name);
      EXPECT_LT(window.width * window.height, camera.width * camera.height / 2) << "step " << step.index << " " << name;
      read_fraction += 1.0 * window.width * window.height / (camera.width * camera.height);
      ++windows;
      for (const Eigen::Vector3d& point : object) {
        Eigen::Vector2d pixel;
        ASSERT_TRUE(camera.Project(camera.cam_from_rig * (rig.turntable.RigFromSample(step.turntable_deg) * point), &pixel));
        EXPECT_TRUE(Inside(window, pixel)) << "step " << step.index << " " << name << ": " << pixel.transpose();
      }
    }
  }
  EXPECT_GT(windowed[scan::ScanObject::kTarget], 8);
  EXPECT_GT(windowed[scan::ScanObject::kChromeSphere], 8);
  EXPECT_GT(windowed[scan::ScanObject::kColourChart], 8);
  EXPECT_LT(read_fraction / windows, 0.25);  // what makes a calibration scan of tac7 fast
}

TEST(ObjectWindowsTest, AnObjectTheRigDoesNotDescribeIsNamed) {
  RigModel rig = Rig("tac7-mini");
  const Result<scan::Preset> preset = scan::LoadPreset(loom::testing::SourceDir() + "/configs/plans/low.yaml");
  ASSERT_TRUE(preset.ok()) << preset.status().ToString();
  const scan::Plan plan = *scan::MakeCalibrationPlan(rig, *preset);
  rig.light_probe.reset();
  const Result<scan::Plan> windowed = WithObjectWindows(plan, rig, {});
  ASSERT_FALSE(windowed.ok());
  EXPECT_NE(windowed.status().message().find("light_probe"), std::string::npos) << windowed.status().ToString();
  EXPECT_FALSE(WithObjectWindows(plan, rig, {.placement_mm = NAN, .margin_px = -1}).ok());
}

}  // namespace
}  // namespace loom::acquisition
