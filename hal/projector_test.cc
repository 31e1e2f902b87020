// The projector backends: the recording fake (what was shown, in order) and the display
// backend (a real window on an X server; Xvfb stands in for the projector's screen).
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <thread>

#include "core/testing/subprocess.h"
#include "hal/display/display_projector.h"
#include "hal/recording/recording_projector.h"

namespace loom::hal {
namespace {

using namespace std::chrono_literals;

scan::Pattern Stripes(const std::string& name, int width, int height, int period) {
  scan::Pattern pattern{name, width, height, std::vector<uint8_t>(static_cast<size_t>(width) * height)};
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) pattern.pixels[y * width + x] = (x / period) % 2 ? 255 : 0;
  }
  return pattern;
}

std::unique_ptr<Projector> MakeProjector(const std::string& yaml) {
  BackendRegistry registry;
  RegisterRecordingBackend(registry);
  RegisterDisplayBackend(registry);
  auto doc = ConfigDocument::LoadString("schema_version: 1\nprojector: " + yaml + "\n", "test.yaml", 1);
  EXPECT_TRUE(doc.ok());
  const ConfigNode node = doc->root().Child("projector");
  DeviceConfig config{"", "", node};
  node.Required("name", &config.name);
  node.Required("backend", &config.backend);
  Result<std::unique_ptr<Projector>> projector = registry.Create<Projector>(config);
  EXPECT_TRUE(projector.ok()) << projector.status().ToString();
  EXPECT_TRUE(doc->Finish().ok()) << doc->Finish().ToString();
  return std::move(*projector);
}

void BringUp(Projector& projector) {
  ASSERT_TRUE(projector.Open().ok());
  const Result<ConfigureReport> report = projector.Configure({});  // native resolution
  ASSERT_TRUE(report.ok());
  ASSERT_EQ(report->outcome, Negotiation::kValid);
  ASSERT_TRUE(projector.Start().ok());
}

TEST(RecordingProjectorTest, RemembersWhatWasShownInOrder) {
  const std::string log = ::testing::TempDir() + "/projector_log.txt";
  std::remove(log.c_str());
  auto projector = MakeProjector("{name: proj, backend: recording, native_width: 64, native_height: 32, log: " + log + "}");
  BringUp(*projector);
  ASSERT_TRUE(projector->Show(Stripes("gray_x_00", 64, 32, 32)).ok());
  ASSERT_TRUE(projector->Show(Stripes("gray_x_01", 64, 32, 16)).ok());
  EXPECT_EQ(projector->current_pattern(), "gray_x_01");
  ASSERT_TRUE(projector->MakeSafe().ok());
  EXPECT_EQ(projector->current_pattern(), "");
  const auto& history = dynamic_cast<RecordingProjector&>(*projector).history();
  ASSERT_EQ(history.size(), 3u);
  EXPECT_EQ(history[0].name, "gray_x_00");
  EXPECT_NE(history[0].checksum, history[1].checksum);
  EXPECT_EQ(history[2].name, "");
  std::ifstream in(log);
  std::string first, second, third;
  std::getline(in, first);
  std::getline(in, second);
  std::getline(in, third);
  EXPECT_TRUE(first.starts_with("show gray_x_00 ")) << first;
  EXPECT_TRUE(second.starts_with("show gray_x_01 ")) << second;
  EXPECT_EQ(third, "blank");
}

TEST(RecordingProjectorTest, RejectsWrongSizesAndResolutions) {
  auto projector = MakeProjector("{name: proj, backend: recording, native_width: 64, native_height: 32}");
  ASSERT_TRUE(projector->Open().ok());
  const Result<ConfigureReport> wrong = projector->Configure({.width = 1920, .height = 1080});
  ASSERT_TRUE(wrong.ok());
  EXPECT_EQ(wrong->outcome, Negotiation::kInvalid);
  ASSERT_TRUE(projector->Configure({.width = 64, .height = 32}).ok());
  ASSERT_TRUE(projector->Start().ok());
  const Status shown = projector->Show(Stripes("too_big", 128, 32, 8));
  EXPECT_EQ(shown.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(shown.ToString().find("projector 'proj'"), std::string::npos);
  EXPECT_NE(shown.message().find("'too_big' is 128x32"), std::string::npos) << shown.message();
}

TEST(DisplayProjectorTest, WithoutADisplayOpenSaysSo) {
  const char* saved = std::getenv("DISPLAY");
  const std::string saved_value = saved ? saved : "";
  unsetenv("DISPLAY");
  auto projector = MakeProjector("{name: proj, backend: display}");
  const Status opened = projector->Open();
  if (saved) setenv("DISPLAY", saved_value.c_str(), 1);
  EXPECT_EQ(opened.code(), StatusCode::kUnavailable);
  EXPECT_NE(opened.message().find("$DISPLAY"), std::string::npos) << opened.ToString();
}

TEST(DisplayProjectorTest, ShowsPatternsFullScreenOnAnXServer) {
  Result<loom::testing::Subprocess> xvfb =
      loom::testing::Subprocess::Start({"Xvfb", ":97", "-screen", "0", "320x200x24", "-nolisten", "tcp"});
  ASSERT_TRUE(xvfb.ok());
  std::this_thread::sleep_for(300ms);  // Xvfb prints nothing when ready
  setenv("DISPLAY", ":97", 1);
  auto projector = MakeProjector("{name: proj, backend: display, native_width: 320, native_height: 200}");
  const Status opened = projector->Open();
  ASSERT_TRUE(opened.ok()) << opened.ToString();
  ASSERT_TRUE(projector->Configure({}).ok());
  ASSERT_TRUE(projector->Start().ok());
  ASSERT_TRUE(projector->Show(Stripes("phase_0", 320, 200, 10)).ok());
  EXPECT_EQ(projector->current_pattern(), "phase_0");
  ASSERT_TRUE(projector->Blank().ok());
  ASSERT_TRUE(projector->Close().ok());
  unsetenv("DISPLAY");
}

}  // namespace
}  // namespace loom::hal
