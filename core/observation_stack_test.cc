#include "core/observation_stack.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>

#include "core/exr_io.h"

namespace loom {
namespace {

namespace fs = std::filesystem;

class ObservationStackTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("loom_stack_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static ObservationStack SmallStack() {
    StackObservation led{ObservationGroup::kColour, "cam0", {1, 2, 600}, 120, {0.1, 0.2, 0.3}, {}, "led 3 through 530 nm"};
    led.emitters.push_back({{100, -200, 300}, Eigen::Vector3d(-1, 2, -3).normalized(), 1e6, 1.5});
    StackObservation strip{ObservationGroup::kLinearLight, "cam1", {-400, 0, 400}, 0, {0.3, 0.4, 0.3}, {}, "strip"};
    for (int k = 0; k < 4; ++k) strip.emitters.push_back({{-10.0 * k, 5, 450}, -Eigen::Vector3d::UnitZ(), 4000, 1});
    ObservationStack stack = MakeObservationStack(3, 2, 0.25, {led, strip});
    stack.rig = "tiny";
    stack.source = "test";
    for (int c = 0; c < stack.image.num_channels(); ++c) {
      if (c >= 3 && c < kStackGeometryChannels) continue;  // the normals stay (0, 0, 1)
      for (int y = 0; y < 2; ++y) {
        for (int x = 0; x < 3; ++x) stack.image.at(c, y, x) = static_cast<float>(c + 0.5 * x + 0.25 * y);
      }
    }
    stack.image.at(ObservationStack::ObservationChannel(1), 1, 2) = std::numeric_limits<float>::quiet_NaN();
    return stack;
  }

  fs::path dir_;
};

TEST_F(ObservationStackTest, RoundTripsChannelsAndTable) {
  const ObservationStack written = SmallStack();
  ASSERT_TRUE(WriteObservationStack(dir_ / "stack.exr", written).ok());
  Result<ObservationStack> read = ReadObservationStack(dir_ / "stack.exr");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->rig, "tiny");
  EXPECT_EQ(read->source, "test");
  EXPECT_EQ(read->pixel_mm, 0.25);
  EXPECT_EQ(read->image.channel_names(), StackChannelNames(2));
  EXPECT_TRUE(std::isnan(read->image.at(7, 1, 2)));
  EXPECT_EQ(read->image.at(6, 1, 2), written.image.at(6, 1, 2));
  ASSERT_EQ(read->observations.size(), 2u);
  const StackObservation& led = read->observations[0];
  EXPECT_EQ(led.group, ObservationGroup::kColour);
  EXPECT_EQ(led.camera, "cam0");
  EXPECT_EQ(led.camera_mm, Eigen::Vector3d(1, 2, 600));
  EXPECT_EQ(led.turntable_deg, 120);
  EXPECT_EQ(led.rgb_weights, Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_EQ(led.description, "led 3 through 530 nm");
  ASSERT_EQ(led.emitters.size(), 1u);
  EXPECT_EQ(led.emitters[0].position_mm, Eigen::Vector3d(100, -200, 300));
  EXPECT_EQ(led.emitters[0].axis, Eigen::Vector3d(-1, 2, -3).normalized());  // doubles survive exactly
  EXPECT_EQ(led.emitters[0].falloff_exponent, 1.5);
  EXPECT_EQ(read->observations[1].group, ObservationGroup::kLinearLight);
  EXPECT_EQ(read->observations[1].emitters.size(), 4u);
}

TEST_F(ObservationStackTest, EveryNthPixelKeepsThosePixelsChannelsAndTheTable) {
  const ObservationStack stack = SmallStack();
  const ObservationStack every = EveryNthPixel(stack, 2);
  ASSERT_EQ(every.image.width(), 2);  // columns 0 and 2 of 3
  ASSERT_EQ(every.image.height(), 1);
  EXPECT_DOUBLE_EQ(every.pixel_mm, 0.5);
  EXPECT_EQ(every.rig, "tiny");
  EXPECT_EQ(every.source, "test");
  ASSERT_EQ(every.observations.size(), 2u);
  EXPECT_EQ(every.observations[1].emitters.size(), 4u);
  ASSERT_EQ(every.image.channel_names(), stack.image.channel_names());
  for (int c = 0; c < stack.image.num_channels(); ++c) {
    EXPECT_EQ(every.image.at(c, 0, 0), stack.image.at(c, 0, 0)) << c;
    EXPECT_EQ(every.image.at(c, 0, 1), stack.image.at(c, 0, 2)) << c;
  }
  const ObservationStack same = EveryNthPixel(stack, 1);
  EXPECT_EQ(same.image.width(), 3);
  EXPECT_TRUE(std::isnan(same.image.at(ObservationStack::ObservationChannel(1), 1, 2)));
}

TEST(PointEmitterTest, FallsOffAsACosinePowerAndIsDarkBehind) {
  const PointEmitter e{{0, 0, 100}, -Eigen::Vector3d::UnitZ(), 1000, 2};
  EXPECT_DOUBLE_EQ(e.IntensityTowards({0, 0, 0}), 1000);
  EXPECT_NEAR(e.IntensityTowards({100, 0, 0}), 1000 * 0.5, 1e-9);  // 45°: cos² = 1/2
  EXPECT_EQ(e.IntensityTowards({0, 0, 200}), 0);
}

TEST_F(ObservationStackTest, RoundTripsDirectionalLightsAndOrthographicCameras) {
  StackObservation photo{ObservationGroup::kColour, "photo", {0, 0, 0}, 0, {1, 0, 0}, {}, "image 7, red"};
  const Eigen::Vector3d towards = Eigen::Vector3d(0.3, -0.2, 0.9).normalized();
  photo.emitters.push_back(PointEmitter::AtInfinity(towards, 0.75));
  photo.view_direction = Eigen::Vector3d::UnitZ();
  ObservationStack written = MakeObservationStack(2, 2, 0.5, {photo});
  ASSERT_TRUE(WriteObservationStack(dir_ / "photo.exr", written).ok());
  Result<ObservationStack> read = ReadObservationStack(dir_ / "photo.exr");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  const StackObservation& o = read->observations.at(0);
  ASSERT_TRUE(o.view_direction.has_value());
  EXPECT_EQ(*o.view_direction, Eigen::Vector3d::UnitZ());
  EXPECT_EQ(o.ViewFrom({100, -50, 3}), Eigen::Vector3d::UnitZ());  // the same everywhere
  ASSERT_EQ(o.emitters.size(), 1u);
  const PointEmitter& light = o.emitters[0];
  EXPECT_TRUE(light.at_infinity);
  EXPECT_TRUE(light.DirectionFrom({5, 5, 0}).isApprox(towards, 1e-15));
  EXPECT_TRUE(light.DirectionFrom({-90, 40, 2}).isApprox(towards, 1e-15));
  EXPECT_EQ(light.IrradianceAt({5, 5, 0}), 0.75);  // no distance to fall off with
  EXPECT_TRUE((light.ShadowTarget({1, 2, 0}, 100) - Eigen::Vector3d(1, 2, 0)).normalized().isApprox(towards, 1e-12));
  // A point camera's view still depends on the pixel; its table entry has no view_direction.
  EXPECT_EQ(ObservationTableToJson(SmallStack().observations).find("view_direction"), std::string::npos);
}

TEST_F(ObservationStackTest, ADirectionalEmitterThatIsNoUnitVectorOrHasNegativeIrradianceNamesTheEntry) {
  StackObservation photo{ObservationGroup::kColour, "photo", {0, 0, 500}, 0, {1, 0, 0}, {}, "image 0"};
  photo.emitters.push_back(PointEmitter::AtInfinity(Eigen::Vector3d::UnitZ(), 1));
  const std::string table = ObservationTableToJson({photo});
  std::string long_direction = table;
  long_direction.replace(long_direction.find("[0.0,0.0,1.0,1.0]"), 17, "[0.0,0.0,2.0,1.0]");
  const auto parsed = ParseObservationTable(long_direction, "photo.exr");
  ASSERT_FALSE(parsed.ok());
  EXPECT_NE(parsed.status().ToString().find("entry 0"), std::string::npos) << parsed.status().ToString();
  EXPECT_NE(parsed.status().ToString().find("not a unit vector"), std::string::npos) << parsed.status().ToString();
  std::string negative = table;
  negative.replace(negative.find("[0.0,0.0,1.0,1.0]"), 17, "[0.0,0.0,1.0,-1.0]");
  EXPECT_FALSE(ParseObservationTable(negative, "photo.exr").ok());
}

TEST_F(ObservationStackTest, AnObservationOfMoreEmittersThanAFitCanSumIsRefusedNamingTheEntry) {
  StackObservation photo{ObservationGroup::kColour, "photo", {0, 0, 500}, 0, {1, 0, 0}, {}, "image 0"};
  photo.emitters.assign(kMaxEmittersPerObservation, PointEmitter::AtInfinity(Eigen::Vector3d::UnitZ(), 1));
  EXPECT_TRUE(ParseObservationTable(ObservationTableToJson({photo}), "photo.exr").ok());
  photo.emitters.push_back(photo.emitters.front());
  const auto parsed = ParseObservationTable(ObservationTableToJson({photo}), "photo.exr");
  ASSERT_FALSE(parsed.ok());
  EXPECT_NE(parsed.status().ToString().find("entry 0"), std::string::npos) << parsed.status().ToString();
  EXPECT_NE(parsed.status().ToString().find(std::to_string(kMaxEmittersPerObservation + 1) + " emitters"), std::string::npos)
      << parsed.status().ToString();
}

TEST_F(ObservationStackTest, AMismatchedTableNamesTheFile) {
  ObservationStack stack = SmallStack();
  // Two observation channels but a table of one: written around WriteObservationStack's CHECK.
  ASSERT_TRUE(WriteExr(dir_ / "bad.exr", stack.image,
                       {{"loom.observation_table", ObservationTableToJson({stack.observations[0]})}, {"loom.pixel_mm", 0.25}})
                  .ok());
  const Result<ObservationStack> read = ReadObservationStack(dir_ / "bad.exr");
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().ToString().find("bad.exr"), std::string::npos) << read.status().ToString();
  EXPECT_NE(read.status().ToString().find("1 observations"), std::string::npos) << read.status().ToString();
}

TEST_F(ObservationStackTest, ACorruptTableNamesTheEntryAndKey) {
  const ObservationStack stack = SmallStack();
  std::string table = ObservationTableToJson(stack.observations);
  table.replace(table.find("\"turntable_deg\""), 15, "\"turntable_dgr\"");
  const Result<std::vector<StackObservation>> parsed = ParseObservationTable(table, "stack.exr");
  ASSERT_FALSE(parsed.ok());
  EXPECT_NE(parsed.status().ToString().find("entry 0"), std::string::npos) << parsed.status().ToString();
  EXPECT_NE(parsed.status().ToString().find("turntable_dgr"), std::string::npos) << parsed.status().ToString();
  EXPECT_FALSE(ParseObservationTable("[{\"group\": ", "stack.exr").ok());
}

TEST_F(ObservationStackTest, ADegenerateNormalOrPixelSizeIsAnErrorNamingIt) {
  ObservationStack stack = SmallStack();
  EXPECT_EQ(stack.Normal(2, 1), Eigen::Vector3d::UnitZ());
  stack.image.at(5, 1, 2) = 0;  // a zero normal at (2, 1)
  ASSERT_TRUE(WriteObservationStack(dir_ / "zero_normal.exr", stack).ok());
  Result<ObservationStack> read = ReadObservationStack(dir_ / "zero_normal.exr");
  ASSERT_FALSE(read.ok());
  for (const char* expected : {"zero_normal.exr", "normal at pixel (2, 1)", "length 0"}) {
    EXPECT_NE(read.status().ToString().find(expected), std::string::npos) << read.status().ToString();
  }
  for (double pixel_mm : {1e-300, 0.0, -1.0, 1e6}) {
    stack = SmallStack();
    stack.pixel_mm = pixel_mm;
    ASSERT_TRUE(WriteObservationStack(dir_ / "pixel.exr", stack).ok());
    read = ReadObservationStack(dir_ / "pixel.exr");
    ASSERT_FALSE(read.ok()) << pixel_mm;
    EXPECT_NE(read.status().ToString().find("loom.pixel_mm"), std::string::npos) << read.status().ToString();
  }
}

TEST_F(ObservationStackTest, InfinityAndNanGeometryAreErrorsNamingChannelAndPixel) {
  ObservationStack stack = SmallStack();
  stack.image.at(7, 0, 1) = std::numeric_limits<float>::infinity();
  ASSERT_TRUE(WriteObservationStack(dir_ / "inf.exr", stack).ok());
  Result<ObservationStack> read = ReadObservationStack(dir_ / "inf.exr");
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().ToString().find("obs0001"), std::string::npos) << read.status().ToString();
  EXPECT_NE(read.status().ToString().find("(1, 0)"), std::string::npos) << read.status().ToString();

  stack = SmallStack();
  stack.image.at(2, 1, 0) = std::numeric_limits<float>::quiet_NaN();  // pos.Z: no height there
  ASSERT_TRUE(WriteObservationStack(dir_ / "nan.exr", stack).ok());
  read = ReadObservationStack(dir_ / "nan.exr");
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().ToString().find("pos.Z"), std::string::npos) << read.status().ToString();
}

}  // namespace
}  // namespace loom
