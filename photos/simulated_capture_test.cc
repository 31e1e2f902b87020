#include "photos/simulated_capture.h"

#include <gtest/gtest.h>

#include <unistd.h>
#include <cmath>
#include <filesystem>

#include "photos/capture_import.h"

namespace loom::photos {
namespace {

namespace fs = std::filesystem;

class SimulatedCaptureTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("loom_simulated_capture_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
  }
  void TearDown() override { fs::remove_all(root_); }
  fs::path root_;
};

// What the ps layout stores, imported at the stored scale, is the rendered radiance over the
// capture's white, and so is the truth: a highlight brighter than 1 sets the white, nothing clips.
TEST_F(SimulatedCaptureTest, APhotometricStereoCaptureStoresItsRadianceAndTruthOverOneWhite) {
  SimulatedCaptureRequest request;
  request.object.size_px = 16;
  request.object.lights = 8;
  request.object.material.a_s = Eigen::Vector3d::Constant(0.8);
  request.object.material.sigma_x = request.object.material.sigma_y = 0.05;
  Result<SimulatedCapture> capture = WriteSimulatedCapture(request, root_ / "ps");
  ASSERT_TRUE(capture.ok()) << capture.status().ToString();
  EXPECT_GT(capture->white, 1) << "this lobe's highlights are brighter than 1: the white must rise above them";
  ASSERT_TRUE(capture->normals.has_value());
  ImportOptions at_stored_scale;
  at_stored_scale.scale = 1.0;
  Result<ImportResult> imported = ImportCapture(root_ / "ps", at_stored_scale);
  ASSERT_TRUE(imported.ok()) << imported.status().ToString();
  ASSERT_EQ(imported->images, 8);
  const sim::ObjectCapture rendered = sim::RenderObjectCapture(request.object);
  double worst = 0;
  for (int k = 0; k < 8; ++k) {
    for (int c = 0; c < 3; ++c) {
      const double stored = imported->stack.image.at(ObservationStack::ObservationChannel(3 * k + c), 8, 8);
      worst = std::max(worst, std::abs(stored * capture->white - rendered.images[k].at(c, 8, 8)));
    }
  }
  EXPECT_LT(worst, 1e-3 * capture->white);
  EXPECT_NEAR(capture->truth.at(3, 8, 8) * capture->white, rendered.truth.at(3, 8, 8), 1e-5);  // a_d.R
}

TEST_F(SimulatedCaptureTest, AFlashCaptureClipsItsBrightestValuesAndSaysWhereTheFlashWas) {
  SimulatedCaptureRequest request;
  request.layout = Layout::kFlash;
  request.sample.size_px = 16;
  request.flash.images = 3;
  request.flash.flash_offset_cm = {0.8, 0, 0};
  Result<SimulatedCapture> capture = WriteSimulatedCapture(request, root_ / "flash");
  ASSERT_TRUE(capture.ok()) << capture.status().ToString();
  EXPECT_EQ(capture->images, 3);
  EXPECT_FALSE(capture->normals.has_value());
  EXPECT_NE(capture->description.find("0.8,0,0 cm beside the lens"), std::string::npos) << capture->description;
  ImportOptions as_the_files_say;  // the flash at the lens, as the files put it
  as_the_files_say.scale = 1.0;
  as_the_files_say.flash_offset_cm = Eigen::Vector3d::Zero();
  Result<ImportResult> imported = ImportCapture(root_ / "flash", as_the_files_say);
  ASSERT_TRUE(imported.ok()) << imported.status().ToString();
  EXPECT_GT(imported->clipped_values, 0);
}

TEST_F(SimulatedCaptureTest, ABadRequestIsRefusedBeforeAnythingIsWritten) {
  SimulatedCaptureRequest request;
  request.object.lights = 0;
  const Result<SimulatedCapture> capture = WriteSimulatedCapture(request, root_ / "none");
  EXPECT_FALSE(capture.ok());
  EXPECT_FALSE(fs::exists(root_ / "none"));
}

}  // namespace
}  // namespace loom::photos
