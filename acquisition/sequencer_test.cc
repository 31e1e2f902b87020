// The sequencer on the simulated tac7-mini: a camera that drops out is retried, and one that
// stays out stops the scan with an error naming it, the rig safe and the store consistent; the
// other devices' timeouts likewise (device_faults).
#include "acquisition/sequencer.h"
#include "core/testing/build_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <set>

#include "core/interrupt.h"
#include "core/testing/shipped_rig.h"
#include "hal/sim/sim_backends.h"
#include "reconstruction/reconstruct.h"
#include "sim/test_materials.h"

namespace loom::acquisition {
namespace {

namespace fs = std::filesystem;

class SequencerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("sequencer_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    model_ = testing::ShippedRigModel("tac7-mini");
    world_ = std::make_shared<hal::SimWorld>(std::make_shared<sim::Scene>(model_, sim::WhiteTile({64, 64, 0.4})), 1);
    rig_ = MakeRig();
    ASSERT_NE(rig_, nullptr);
    plan_ = *scan::MakeMaterialPlan(model_, TinyPreset({0}, 1));
  }

  // One colour view, two exposures a bracket, the coarsest structured light.
  static scan::Preset TinyPreset(std::vector<double> turntable_deg, int linear_light_positions) {
    scan::Preset preset;
    preset.name = "tiny";
    preset.turntable_deg = std::move(turntable_deg);
    preset.colour_views_deg = {0};
    preset.linear_light_positions = linear_light_positions;
    preset.exposure.max_exposures = 2;
    preset.gray_bits = 1;
    preset.phase_steps = 1;
    return preset;
  }

  // The sim rig on world_, as a new `loom scan` process would load it (`path`: another YAML).
  std::unique_ptr<hal::Rig> MakeRig(const fs::path& path = loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml") {
    hal::BackendRegistry registry;
    hal::RegisterSimBackends(registry, world_);
    auto rig = hal::Rig::Load(path, registry);
    EXPECT_TRUE(rig.ok()) << rig.status().ToString();
    return rig.ok() ? std::move(*rig) : nullptr;
  }

  scan::CaptureStore NewStore() { return std::move(*scan::CaptureStore::Create(dir_, {"rig", "white tile", plan_})); }

  fs::path dir_;
  RigModel model_;
  std::shared_ptr<hal::SimWorld> world_;
  std::unique_ptr<hal::Rig> rig_;
  scan::Plan plan_;
};

// A step with a linearity series (plan.h): after its bracket, exposures halving from the one
// that brings the brightest pixels to 90 % of full scale.
TEST_F(SequencerTest, ALinearitySeriesFollowsTheBracket) {
  scan::Plan plan = plan_;
  const auto lit = std::find_if(plan.steps.begin(), plan.steps.end(),
                                [](const scan::Step& s) { return s.kind == scan::StepKind::kMonochrome; });
  ASSERT_NE(lit, plan.steps.end());
  scan::Step series = *lit;
  series.index = 1;
  series.exposure.linearity_series = 4;
  plan.steps = {plan.steps.front(), series};  // the dark step, then the lit one
  scan::CaptureStore store = std::move(*scan::CaptureStore::Create(dir_, {"rig", "white tile", plan}));
  Sequencer sequencer(*rig_, plan, store);
  const Status done = sequencer.Run();
  ASSERT_TRUE(done.ok()) << done.ToString();
  std::vector<const scan::FrameRecord*> frames;
  for (const scan::FrameRecord& record : store.records()) {
    if (record.key.step == 1 && record.key.camera == "cam0") frames.push_back(&record);
  }
  ASSERT_GE(frames.size(), 5u);
  const size_t first = frames.size() - 4;
  for (size_t i = first + 1; i < frames.size(); ++i) {
    EXPECT_DOUBLE_EQ(frames[i]->metadata.exposure_us, frames[i - 1]->metadata.exposure_us / 2) << i;
  }
  // The series' first frame: its brightest pixels near 90 % of the 12-bit range above black.
  const Result<scan::RawFrame> top = store.ReadFrame(*frames[first]);
  ASSERT_TRUE(top.ok()) << top.status().ToString();
  std::vector<uint16_t> values = top->pixels;
  std::nth_element(values.begin(), values.begin() + static_cast<long>(0.999 * (values.size() - 1)), values.end());
  const double peak = values[static_cast<size_t>(0.999 * (values.size() - 1))] - 64.0;
  EXPECT_NEAR(peak / (4095 - 64), 0.9, 0.05);
}

// A step's windows (a calibration object's, acquisition/crop_windows.h): its cameras read only
// them, through the camera's region of interest, and the next step reads the scan's own region.
TEST_F(SequencerTest, AStepsWindowsAreReadAndTheNextStepReadsTheWholeSensorAgain) {
  scan::Plan plan = plan_;
  ASSERT_GE(plan.steps.size(), 3u);
  const scan::Roi window{8, 16, 64, 48};
  plan.steps[1].windows = {{"cam0", window}};
  scan::CaptureStore store = std::move(*scan::CaptureStore::Create(dir_, {"rig", "white tile", plan}));
  Sequencer sequencer(*rig_, plan, store);
  const Status done = sequencer.Run();
  ASSERT_TRUE(done.ok()) << done.ToString();
  const CameraModel& camera = *model_.FindCamera("cam0");
  const scan::Roi whole{0, 0, camera.width, camera.height};
  int windowed = 0;
  for (const scan::FrameRecord& record : store.records()) {
    const scan::Roi expected = record.key.step == 1 && record.key.camera == "cam0" ? window : whole;
    EXPECT_EQ(record.metadata.roi, expected) << "step " << record.key.step << " " << record.key.camera;
    const Result<scan::RawFrame> frame = store.ReadFrame(record);
    ASSERT_TRUE(frame.ok()) << frame.status().ToString();
    EXPECT_EQ(frame->width, expected.width);
    EXPECT_EQ(frame->height, expected.height);
    windowed += expected == window;
  }
  EXPECT_GE(windowed, 1);
}

// tac7-mini.yaml's settle times: LEDs 20 ms (a 2 s warm-up when first on), turntable 500 ms.
// Waited on the simulated rig's virtual clock, the longest of what a step changed, and recorded.
TEST_F(SequencerTest, ItWaitsTheSettleTimesOfWhatAStepChangesAndRecordsThem) {
  scan::Plan plan = plan_;
  const auto lit = std::find_if(plan.steps.begin(), plan.steps.end(),
                                [](const scan::Step& s) { return s.kind == scan::StepKind::kMonochrome; });
  ASSERT_NE(lit, plan.steps.end());
  scan::Step first_light = *lit;  // LED on for the first time: its warm-up
  first_light.index = 1;
  first_light.turntable_deg = 0;
  first_light.leds = {{3, 1000}};
  scan::Step turned = first_light;  // the same LED, the turntable turned
  turned.index = 2;
  turned.turntable_deg = 120;
  scan::Step unchanged = turned;  // nothing changes: no wait, still settled since the turn
  unchanged.index = 3;
  scan::Step other_led = turned;  // another LED: its settle, no second warm-up
  other_led.index = 4;
  other_led.leds = {{5, 1000}};
  plan.steps = {plan.steps.front(), first_light, turned, unchanged, other_led};
  scan::CaptureStore store = std::move(*scan::CaptureStore::Create(dir_, {"rig", "white tile", plan}));
  const double start_s = rig_->clock().NowS();
  Sequencer sequencer(*rig_, plan, store);
  const Status done = sequencer.Run();
  ASSERT_TRUE(done.ok()) << done.ToString();

  const std::map<int, double> expected_ms = {{1, 2000}, {2, 500}, {3, 500}, {4, 20}};
  int checked = 0;
  for (const scan::FrameRecord& record : store.records()) {
    if (record.key.step == 0) continue;
    EXPECT_NEAR(record.metadata.rig_state.settled_ms, expected_ms.at(record.key.step), 1e-9) << record.file;
    ++checked;
  }
  EXPECT_GE(checked, 8);
  // Virtual time: at least the waits above passed on the rig's clock, none of it slept.
  EXPECT_GE(rig_->clock().NowS() - start_s, 2.0 + 0.5 + 0.02);
  // The journal keeps them: read back from disk, as a resumed scan or reconstruct would.
  const Result<scan::CaptureStore> reopened = scan::CaptureStore::Open(dir_);
  ASSERT_TRUE(reopened.ok()) << reopened.status().ToString();
  for (const scan::FrameRecord& record : reopened->records()) {
    if (record.key.step == 2) {
      EXPECT_NEAR(record.metadata.rig_state.settled_ms, 500, 1e-9) << record.file;
    }
  }
}

TEST_F(SequencerTest, ACameraThatDropsOutBrieflyIsRetried) {
  world_->camera_failures["cam1"] = 2;
  scan::CaptureStore store = NewStore();
  Sequencer sequencer(*rig_, plan_, store);
  const Status done = sequencer.Run();
  ASSERT_TRUE(done.ok()) << done.ToString();
  EXPECT_EQ(store.steps_done(), static_cast<int>(plan_.steps.size()));
  EXPECT_EQ(world_->camera_failures["cam1"], 0);  // both injected failures were met
}

TEST_F(SequencerTest, ACameraThatStaysOutStopsTheScanCleanly) {
  {
    scan::CaptureStore store = NewStore();
    Sequencer sequencer(*rig_, plan_, store);
    int steps = 0;
    // Let a few steps pass, then pull cam1's cable for good.
    const Status done = sequencer.Run([&](const ScanProgress&) {
      if (++steps == 3) world_->camera_failures["cam1"] = -1;
    });
    ASSERT_FALSE(done.ok());
    EXPECT_EQ(done.code(), StatusCode::kUnavailable);
    EXPECT_EQ(done.subject(), "camera 'cam1' (sim virtual cam1)");
    EXPECT_NE(done.message().find("step 3"), std::string::npos) << done.ToString();
    hal::SafeStateGuard guard(*rig_);  // what loom scan holds around the sequencer
  }
  EXPECT_TRUE(world_->state.leds.empty());
  const Result<scan::CaptureStore> reopened = scan::CaptureStore::Open(dir_, /*repair=*/true);
  ASSERT_TRUE(reopened.ok()) << reopened.status().ToString();
  EXPECT_EQ(reopened->steps_done(), 3);
  EXPECT_FALSE(reopened->StepDone(3));
  for (const scan::FrameRecord& record : reopened->records()) EXPECT_TRUE(reopened->ReadFrame(record).ok()) << record.file;
}

// Every device a step sets, timing out now and then: each step's settings are applied again
// (device_faults), and the scan ends complete.
TEST_F(SequencerTest, DevicesThatTimeOutBrieflyAreSetAgain) {
  plan_ = *scan::MakeMaterialPlan(model_, TinyPreset({0, 90}, 1));
  world_->device_failures = {{"leds", 2}, {"wheel0", 1}, {"turntable", 1}, {"linear_light", 2}, {"projector", 1}};
  scan::CaptureStore store = NewStore();
  SequencerOptions options;
  options.device_faults.retries = 7;  // one step may meet all of them
  Sequencer sequencer(*rig_, plan_, store, options);
  const Status done = sequencer.Run();
  ASSERT_TRUE(done.ok()) << done.ToString();
  EXPECT_EQ(store.steps_done(), static_cast<int>(plan_.steps.size()));
  for (const auto& [device, left] : world_->device_failures) EXPECT_EQ(left, 0) << device << "'s faults were not all met";
}

// The LED controller timing out while the rig's state is read for a capture: the step is set
// again and the state read again (device_faults), and the scan ends complete.
TEST_F(SequencerTest, ADeviceThatTimesOutWhileItsStateIsReadIsSetAgain) {
  plan_ = *scan::MakeMaterialPlan(model_, TinyPreset({0}, 1));
  world_->read_failures = {{"leds", 2}};
  scan::CaptureStore store = NewStore();
  SequencerOptions options;
  options.device_faults = {.retries = 2, .retry_delay_ms = 10};
  Sequencer sequencer(*rig_, plan_, store, options);
  const Status done = sequencer.Run();
  ASSERT_TRUE(done.ok()) << done.ToString();
  EXPECT_EQ(store.steps_done(), static_cast<int>(plan_.steps.size()));
  EXPECT_EQ(world_->read_failures["leds"], 0);
}

// One that stays out there stops the scan naming the reading, the step and the attempts.
TEST_F(SequencerTest, ADeviceThatStaysOutWhileItsStateIsReadStopsTheScanNamingIt) {
  plan_ = *scan::MakeMaterialPlan(model_, TinyPreset({0}, 1));
  world_->read_failures = {{"leds", -1}};
  scan::CaptureStore store = NewStore();
  SequencerOptions options;
  options.device_faults = {.retries = 1, .retry_delay_ms = 10};
  Sequencer sequencer(*rig_, plan_, store, options);
  const Status done = sequencer.Run();
  ASSERT_FALSE(done.ok());
  EXPECT_EQ(done.code(), StatusCode::kTimeout) << done.ToString();
  for (const char* part : {"reading the rig's state at step", "after 2 attempts", "leds"}) {
    EXPECT_NE(done.ToString().find(part), std::string::npos) << part << " in " << done.ToString();
  }
}

// A device that stays out: the scan stops at that step with an error naming the device, the
// step and the attempts; the rig is made safe; once the device is back the scan resumes and ends.
TEST_F(SequencerTest, ADeviceThatStaysOutStopsTheScanNamingItAndResumesAfterwards) {
  {
    scan::CaptureStore store = NewStore();
    SequencerOptions options;
    options.device_faults = {.retries = 1, .retry_delay_ms = 10};
    Sequencer sequencer(*rig_, plan_, store, options);
    int steps = 0;
    const Status done = sequencer.Run([&](const ScanProgress&) {
      if (++steps == 3) world_->device_failures["leds"] = -1;
    });
    ASSERT_FALSE(done.ok());
    EXPECT_EQ(done.code(), StatusCode::kTimeout) << done.ToString();
    EXPECT_NE(done.subject().find("leds"), std::string::npos) << done.ToString();
    EXPECT_NE(done.message().find(", after 2 attempts"), std::string::npos) << done.ToString();
    hal::SafeStateGuard guard(*rig_);
  }
  EXPECT_TRUE(world_->state.leds.empty());
  world_->device_failures.clear();
  Result<scan::CaptureStore> reopened = scan::CaptureStore::Open(dir_, /*repair=*/true);
  ASSERT_TRUE(reopened.ok()) << reopened.status().ToString();
  const int stopped_at = reopened->steps_done();  // the first step that lights an LED after the 3rd
  EXPECT_GE(stopped_at, 3);
  EXPECT_LT(stopped_at, static_cast<int>(plan_.steps.size()));
  const std::unique_ptr<hal::Rig> rig = MakeRig();  // as `loom scan --resume` loads it
  Sequencer resumed(*rig, plan_, *reopened);
  const Status done = resumed.Run();
  ASSERT_TRUE(done.ok()) << done.ToString();
  EXPECT_EQ(reopened->steps_done(), static_cast<int>(plan_.steps.size()));
}

// Other errors are not retried: an LED drive out of the controller's range fails at once.
TEST_F(SequencerTest, ADeviceErrorThatIsNotATimeoutIsNotRetried) {
  scan::Plan plan = plan_;
  for (scan::Step& step : plan.steps) {
    for (scan::LedDrive& drive : step.leds) drive.current_ma = 1e6;
  }
  scan::CaptureStore store = std::move(*scan::CaptureStore::Create(dir_, {"rig", "white tile", plan}));
  Sequencer sequencer(*rig_, plan, store);
  const Status done = sequencer.Run();
  ASSERT_FALSE(done.ok());
  EXPECT_EQ(done.code(), StatusCode::kInvalidArgument) << done.ToString();
  EXPECT_NE(done.subject().find("leds"), std::string::npos) << done.ToString();
  EXPECT_EQ(done.message().find("attempts"), std::string::npos) << done.ToString();
}

TEST(DeviceFaultPolicyTest, TheRigFilesSectionIsReadAndCheckedNamingTheKey) {
  const std::string rig = "name: r\nschema_version: 1\ndevices: {}\n";
  Result<RigFile> defaults = RigFile::Parse(rig, "r.yaml");
  ASSERT_TRUE(defaults.ok()) << defaults.status().ToString();
  EXPECT_EQ(ReadDeviceFaultPolicy(*defaults).retries, DeviceFaultPolicy{}.retries);

  Result<RigFile> given = RigFile::Parse(rig + "device_faults: {retries: 5, retry_delay_ms: 250}\n", "r.yaml");
  ASSERT_TRUE(given.ok()) << given.status().ToString();
  const DeviceFaultPolicy policy = ReadDeviceFaultPolicy(*given);
  EXPECT_EQ(policy.retries, 5);
  EXPECT_EQ(policy.retry_delay_ms, 250);
  EXPECT_TRUE(given->Finish().ok()) << given->Finish().ToString();

  Result<RigFile> bad = RigFile::Parse(rig + "device_faults: {retries: -1, retry_delay_ms: .nan, retry: 3}\n", "r.yaml");
  ASSERT_TRUE(bad.ok()) << bad.status().ToString();
  ReadDeviceFaultPolicy(*bad);
  const Status finished = bad->Finish();
  ASSERT_FALSE(finished.ok());
  for (const char* key : {"retries", "retry_delay_ms", "retry"}) {
    EXPECT_NE(finished.ToString().find(std::string("device_faults.") + key), std::string::npos)
        << key << ": " << finished.ToString();
  }
}

TEST(DarkLevelTest, MedianAndRobustSpreadIgnoreHotPixels) {
  scan::RawFrame dark;
  dark.width = 100;
  dark.height = 10;
  for (int i = 0; i < 1000; ++i) dark.pixels.push_back(static_cast<uint16_t>(64 + (i % 3) - 1));  // 63, 64, 65
  for (int i = 0; i < 10; ++i) dark.pixels[i * 97] = 4095;                                        // hot pixels
  const scan::DarkLevel level = scan::MeasureDarkLevel(dark);
  EXPECT_EQ(level.black_dn, 64);
  EXPECT_NEAR(level.noise_dn, 1.4826, 1e-9);  // MAD 1 of a spread whose std is 0.82: robust, not exact
}

TEST_F(SequencerTest, TheDarkStepSetsTheBlackLevelTheSimulatedSensorHas) {
  ASSERT_EQ(plan_.steps.front().kind, scan::StepKind::kDark);
  {
    scan::CaptureStore store = NewStore();
    Sequencer sequencer(*rig_, plan_, store);
    ASSERT_TRUE(sequencer.Run().ok());
    ASSERT_EQ(sequencer.dark_levels().size(), model_.cameras.size());
    for (const auto& [camera, level] : sequencer.dark_levels()) {
      EXPECT_NEAR(level.black_dn, model_.cameras[0].sensor.dark_offset_dn, 1) << camera;
      EXPECT_GT(level.noise_dn, 0.29) << camera;
      EXPECT_LT(level.noise_dn, 3) << camera;  // 2.5 e- read noise at ~2.4 e-/DN
    }
  }
  // Resumed by a new process (here: with every step done), the levels come from the stored
  // dark frames.
  Result<scan::CaptureStore> reopened = scan::CaptureStore::Open(dir_, /*repair=*/true);
  ASSERT_TRUE(reopened.ok()) << reopened.status().ToString();
  const std::unique_ptr<hal::Rig> fresh_rig = MakeRig();
  Sequencer resumed(*fresh_rig, plan_, *reopened);
  const Status done = resumed.Run();
  ASSERT_TRUE(done.ok()) << done.ToString();
  EXPECT_EQ(resumed.dark_levels().size(), model_.cameras.size());
}

// A killed process leaves the rig as it was: a wheel in a filter, the strip lit, a pattern on the
// projector. The resumed scan sets every device where the plan has it, so its frames equal an
// uninterrupted scan's — pixels and recorded rig state — wherever the scan was stopped. (The sim
// world outlives the rig objects here, as real hardware outlives the process.)
TEST_F(SequencerTest, AScanResumedOnARigLeftAsItWasEqualsAnUninterruptedOne) {
  // Two turntable angles: the first angle's strip positions are followed by point-lit steps.
  const scan::Plan plan = *scan::MakeMaterialPlan(model_, TinyPreset({0, 180}, 2));
  std::map<std::string, std::pair<std::string, scan::RigState>> expected;
  {
    scan::CaptureStore reference = *scan::CaptureStore::Create(dir_ / "reference", {"rig", "white tile", plan});
    ASSERT_TRUE(Sequencer(*rig_, plan, reference).Run().ok());
    for (const scan::FrameRecord& r : reference.records()) expected[r.file] = {r.checksum, r.metadata.rig_state};
  }
  // Stopped after the last step of a run of each of these kinds (the next step is of another
  // kind), then resumed by a "new process".
  for (const scan::StepKind kind : {scan::StepKind::kStructuredLight, scan::StepKind::kColour, scan::StepKind::kLinearLight}) {
    SCOPED_TRACE(std::string(scan::StepKindName(kind)));
    world_ = std::make_shared<hal::SimWorld>(std::make_shared<sim::Scene>(model_, sim::WhiteTile({64, 64, 0.4})), 1);
    const fs::path dir = dir_ / std::string(scan::StepKindName(kind));
    {
      const std::unique_ptr<hal::Rig> killed = MakeRig();
      scan::CaptureStore store = *scan::CaptureStore::Create(dir, {"rig", "white tile", plan});
      Sequencer sequencer(*killed, plan, store);
      const Status stopped = sequencer.Run([&](const ScanProgress& p) {
        const size_t done = static_cast<size_t>(p.steps_done);
        if (plan.steps[done - 1].kind == kind && done < plan.steps.size() && plan.steps[done].kind != kind) {
          SetInterruptRequested(true);
        }
      });
      SetInterruptRequested(false);
      ASSERT_EQ(stopped.code(), StatusCode::kCancelled) << stopped.ToString();
    }
    Result<scan::CaptureStore> store = scan::CaptureStore::Open(dir, /*repair=*/true);
    ASSERT_TRUE(store.ok()) << store.status().ToString();
    const std::unique_ptr<hal::Rig> resumed = MakeRig();
    ASSERT_TRUE(Sequencer(*resumed, plan, *store).Run().ok());
    ASSERT_EQ(store->records().size(), expected.size());
    for (const scan::FrameRecord& r : store->records()) {
      ASSERT_TRUE(expected.contains(r.file)) << r.file;
      EXPECT_EQ(r.checksum, expected[r.file].first) << r.file;
      EXPECT_EQ(r.metadata.rig_state.filter_slots, expected[r.file].second.filter_slots) << r.file;
      EXPECT_EQ(r.metadata.rig_state.linear_light_on, expected[r.file].second.linear_light_on) << r.file;
      EXPECT_EQ(r.metadata.rig_state.projector_pattern, expected[r.file].second.projector_pattern) << r.file;
    }
  }
}

// tac7-mini.yaml with its cameras on the LED controller's trigger output: one pulse per capture
// exposes both cameras, and the scan's frames are those of the software-triggered scan.
TEST_F(SequencerTest, AHardwareTriggeredScanGivesTheFramesOfASoftwareTriggeredOne) {
  std::map<std::string, std::string> software;
  {
    scan::CaptureStore store = *scan::CaptureStore::Create(dir_ / "software", {"rig", "white tile", plan_});
    ASSERT_TRUE(Sequencer(*rig_, plan_, store).Run().ok());
    for (const scan::FrameRecord& r : store.records()) software[r.file] = r.checksum;
  }
  std::ifstream in(loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml");
  std::string yaml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (size_t at; (at = yaml.find("trigger: software")) != std::string::npos;) yaml.replace(at, 17, "trigger: hardware");
  yaml.replace(yaml.find("\ndevices:\n") + 10, 0, "  trigger: {source: leds}\n");
  const fs::path hardware_yaml = dir_ / "tac7-mini-hardware-trigger.yaml";
  std::ofstream(hardware_yaml) << yaml;

  world_ = std::make_shared<hal::SimWorld>(std::make_shared<sim::Scene>(model_, sim::WhiteTile({64, 64, 0.4})), 1);
  const std::unique_ptr<hal::Rig> rig = MakeRig(hardware_yaml);
  ASSERT_NE(rig, nullptr);
  ASSERT_EQ(rig->trigger_source(), hal::TriggerSource::kLedController);
  scan::CaptureStore store = *scan::CaptureStore::Create(dir_ / "hardware", {"rig", "white tile", plan_});
  const Status done = Sequencer(*rig, plan_, store).Run();
  ASSERT_TRUE(done.ok()) << done.ToString();
  ASSERT_EQ(store.records().size(), software.size());
  std::set<std::pair<int, int>> captures;  // (step, exposure): one pulse each, for both cameras
  for (const scan::FrameRecord& r : store.records()) {
    ASSERT_TRUE(software.contains(r.file)) << r.file;
    EXPECT_EQ(r.checksum, software[r.file]) << r.file;
    captures.insert({r.key.step, r.key.exposure});
  }
  EXPECT_EQ(world_->trigger_pulses(), static_cast<int>(captures.size()));
}

// LEDs whose output falls by 5 % through the scan (the sim's output drift): the plan's drift
// references measure it, and reconstruction corrects the LED-lit observations to within 0.5 %
// of a scan whose LEDs hold steady; uncorrected they are several percent off.
TEST_F(SequencerTest, DriftReferencesCorrectLedsAndAStripThatFadeThroughTheScan) {
  RigModel without_projector = model_;  // no structured light: the tile is taken as flat, as it is
  without_projector.projector.reset();
  const scan::Plan plan = *scan::MakeMaterialPlan(without_projector, TinyPreset({0, 180}, 4), {.reference_every_steps = 8});
  ASSERT_GE(plan.Images(scan::StepKind::kDriftReference), 16);
  reconstruction::ReconstructOptions options;
  options.width_px = options.height_px = 24;
  options.pixel_mm = 0.4;
  const auto scan_and_reconstruct = [&](const std::string& name, double drift_percent,
                                        bool correct) -> Result<reconstruction::Reconstruction> {
    world_ = std::make_shared<hal::SimWorld>(std::make_shared<sim::Scene>(model_, sim::WhiteTile({64, 64, 0.4})), 1);
    world_->set_led_drift(drift_percent, 40);
    world_->set_strip_drift(drift_percent, 20);  // the strip lights fewer frames: a fade as deep over them
    const std::unique_ptr<hal::Rig> rig = MakeRig();
    scan::CaptureStore store = *scan::CaptureStore::Create(dir_ / name, {"rig", "white tile", plan});
    LOOM_RETURN_IF_ERROR(Sequencer(*rig, plan, store).Run());
    reconstruction::ReconstructOptions o = options;
    o.correct_light_drift = correct;
    return reconstruction::Reconstruct(store, model_, o);
  };
  const Result<reconstruction::Reconstruction> steady = scan_and_reconstruct("steady", 0, true);
  const Result<reconstruction::Reconstruction> corrected = scan_and_reconstruct("fading", -5, true);
  const Result<reconstruction::Reconstruction> uncorrected = scan_and_reconstruct("fading-uncorrected", -5, false);
  ASSERT_TRUE(steady.ok()) << steady.status().ToString();
  ASSERT_TRUE(corrected.ok()) << corrected.status().ToString();
  ASSERT_TRUE(uncorrected.ok()) << uncorrected.status().ToString();
  EXPECT_LT(steady->light_drift.back().second, 1.001);
  EXPECT_GT(steady->light_drift.back().second, 0.999);
  EXPECT_LT(corrected->light_drift.back().second, 0.97);  // measured: the LEDs faded
  ASSERT_FALSE(corrected->linear_light_drift.empty());
  EXPECT_LT(corrected->linear_light_drift.back().second, 0.97);  // and the strip
  EXPECT_TRUE(corrected->light_drift_corrected);
  EXPECT_FALSE(uncorrected->light_drift_corrected);

  // Median |fading / steady − 1| over the samples of the LED-lit (or the strip-lit) observations.
  const auto median_error = [&](const reconstruction::Reconstruction& fading, bool strip_lit) {
    std::vector<double> errors;
    const ObservationStack& a = steady->stack;
    for (size_t k = 0; k < a.observations.size(); ++k) {
      if ((a.observations[k].group == ObservationGroup::kLinearLight) != strip_lit) continue;
      const int channel = ObservationStack::ObservationChannel(static_cast<int>(k));
      for (int y = 0; y < a.image.height(); ++y) {
        for (int x = 0; x < a.image.width(); ++x) {
          const double reference = a.image.at(channel, y, x), value = fading.stack.image.at(channel, y, x);
          if (std::isfinite(reference) && std::isfinite(value) && reference > 0)
            errors.push_back(std::abs(value / reference - 1));
        }
      }
    }
    EXPECT_GT(errors.size(), 1000u);
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    return errors[errors.size() / 2];
  };
  for (const bool strip_lit : {false, true}) {
    const double corrected_error = median_error(*corrected, strip_lit), uncorrected_error = median_error(*uncorrected, strip_lit);
    std::cout << (strip_lit ? "strip" : "LED") << "-lit observations against a steady scan's: " << 100 * corrected_error
              << " % corrected, " << 100 * uncorrected_error << " % not\n";
    EXPECT_LT(corrected_error, 0.005) << strip_lit;
    EXPECT_GT(uncorrected_error, 0.015) << strip_lit;
  }
}

TEST(SequencerOptionsTest, EveryBadValueIsRefusedNamingItsField) {
  EXPECT_TRUE(SequencerOptions{}.Check().ok());
  SequencerOptions bad;
  bad.max_retries = -1;
  bad.device_faults.retry_delay_ms = -1;
  bad.black_level_dn = std::nan("");
  bad.noise_floor_sigmas = 0;
  bad.exposure_factor = 1;  // a bracket that never grows
  bad.phase_steps = 0;
  const Status status = bad.Check();
  ASSERT_FALSE(status.ok());
  for (const char* field : {"max_retries", "device_faults.retry_delay_ms", "black_level_dn", "noise_floor_sigmas",
                            "exposure_factor", "phase_steps"}) {
    EXPECT_NE(status.message().find(field), std::string::npos) << field << " in " << status.message();
  }
}

}  // namespace
}  // namespace loom::acquisition
