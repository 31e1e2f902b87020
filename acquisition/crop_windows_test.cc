#include "acquisition/crop_windows.h"

#include <gtest/gtest.h>

#include <string>

#include "core/geometry.h"
#include "core/rig_file.h"

namespace loom::acquisition {
namespace {

RigModel Rig(const std::string& name) {
  const Result<RigModel> rig = LoadRigModel(std::string(LOOM_SOURCE_DIR) + "/configs/rig/" + name + ".yaml");
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

}  // namespace
}  // namespace loom::acquisition
