// The sim backend: devices that share one virtual world, frames rendered from the rig state.
#include "hal/sim/sim_backends.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/interrupt.h"
#include "hal/device_status.h"
#include "hal/rig.h"
#include "sim/test_materials.h"

namespace loom::hal {
namespace {

constexpr char kRigYaml[] = R"(
cameras:
  - {name: top, backend: sim, supersampling: 1,
     settings: {pixel_format: Mono12, exposure_us: 20000, trigger: software}}
leds: {name: leds, backend: sim}
filter_wheels: [{name: wheel0, backend: sim}]
turntable: {name: turntable, backend: sim}
linear_light: {name: strip, backend: sim}
projector: {name: projector, backend: sim}
)";

RigModel SmallRig() {
  RigModel rig;
  CameraModel camera;
  camera.name = "top";
  camera.width = camera.height = 48;
  camera.K << 600, 0, 23.5, 0, 600, 23.5, 0, 0, 1;
  Eigen::Matrix3d down;
  down << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  camera.cam_from_rig = MakeRigid(down, -down * Eigen::Vector3d(0, 0, 500));
  camera.sensor.sensitivity = 1.3e6;
  rig.cameras.push_back(camera);
  for (double azimuth : {0.0, 90.0, 180.0}) {
    LedModel led;
    led.position_mm = 600 * DirectionFromSpherical(DegToRad(50), DegToRad(azimuth));
    led.axis = -led.position_mm.normalized();
    rig.leds.push_back(led);
  }
  rig.filter_wheels.push_back({"wheel0", 1, {FilterModel::BandPass(450, 40), FilterModel::BandPass(650, 40)}});
  rig.linear_light = LinearLightModel{};
  ProjectorModel projector;
  projector.width = 32;
  projector.height = 24;
  projector.K << 100, 0, 15.5, 0, 100, 11.5, 0, 0, 1;
  projector.proj_from_rig = camera.cam_from_rig;  // beside the camera, looking down
  rig.projector = projector;
  return rig;
}

class SimBackendsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    world_ = std::make_shared<SimWorld>(
        std::make_shared<sim::Scene>(SmallRig(), sim::ColourChart(ColourChartModel{.patch_mm = 4.0}, {64, 64, 0.5})), 3);
    auto rig = MakeRig(kRigYaml);
    ASSERT_TRUE(rig.ok()) << rig.status().ToString();
    rig_ = std::move(*rig);
    ASSERT_TRUE(rig_->OpenAndConfigure().ok());
    ASSERT_TRUE(rig_->StartAll().ok());
  }

  // A rig of sim devices in this test's world, from a devices section.
  Result<std::unique_ptr<Rig>> MakeRig(const std::string& devices_yaml) {
    BackendRegistry registry;
    RegisterSimBackends(registry, world_);
    // The devices section at the top level of the document.
    auto doc = ConfigDocument::LoadString("schema_version: 1" + devices_yaml, "sim.yaml", 1);
    if (!doc.ok()) return doc.status();
    Result<std::unique_ptr<Rig>> rig = Rig::Create(doc->root(), registry, "sim");
    if (!rig.ok()) return rig.status();
    LOOM_RETURN_IF_ERROR(doc->Finish());
    return rig;
  }

  double MeanDn(const scan::RawFrame& frame) {
    double sum = 0;
    for (uint16_t v : frame.pixels) sum += v;
    return sum / frame.pixels.size();
  }

  std::shared_ptr<SimWorld> world_;
  std::unique_ptr<Rig> rig_;
};

TEST_F(SimBackendsTest, LightsChangeWhatTheCameraRenders) {
  Camera& camera = *rig_->cameras()[0];
  const Result<scan::RawFrame> dark = rig_->Snap(camera);
  ASSERT_TRUE(dark.ok()) << dark.status().ToString();
  EXPECT_NEAR(MeanDn(*dark), 64, 1.0);  // the dark offset
  const scan::LedDrive drive[] = {{0, 800}};
  ASSERT_TRUE(rig_->leds()->Drive(drive).ok());
  const Result<scan::RawFrame> lit = rig_->Snap(camera);
  ASSERT_TRUE(lit.ok());
  EXPECT_GT(MeanDn(*lit), 150);
  EXPECT_EQ(lit->metadata.rig_state.leds_on, (std::vector<scan::LedDrive>{{0, 800}}));
  EXPECT_EQ(lit->metadata.camera_serial, "SIM-top");
}

TEST_F(SimBackendsTest, SameStateSameFrameAndTheTurntableMovesTheSample) {
  Camera& camera = *rig_->cameras()[0];
  const scan::LedDrive drive[] = {{0, 800}};
  ASSERT_TRUE(rig_->leds()->Drive(drive).ok());
  const scan::RawFrame a = *rig_->Snap(camera);
  const scan::RawFrame b = *rig_->Snap(camera);
  EXPECT_EQ(a.pixels, b.pixels);  // what a resumed scan relies on
  ASSERT_TRUE(rig_->turntable()->MoveTo(90).ok());
  const scan::RawFrame turned = *rig_->Snap(camera);
  EXPECT_NE(turned.pixels, a.pixels);
  EXPECT_EQ(turned.metadata.rig_state.turntable_deg, 90);
}

// A camera traces its rays once per turntable angle (sim::CameraHits) and renders every step
// at that angle from them: its frames are those of a camera that renders each afresh.
TEST_F(SimBackendsTest, FramesFromRaysTracedForAnEarlierStepAreAFreshCamerasFrames) {
  Result<std::unique_ptr<Rig>> fresh_rig = MakeRig(kRigYaml);  // its camera has traced nothing
  ASSERT_TRUE(fresh_rig.ok()) << fresh_rig.status().ToString();
  ASSERT_TRUE((*fresh_rig)->OpenAndConfigure().ok());
  ASSERT_TRUE((*fresh_rig)->StartAll().ok());
  Camera& camera = *rig_->cameras()[0];
  const scan::LedDrive first[] = {{0, 800}};
  const scan::LedDrive second[] = {{1, 1000}};
  ASSERT_TRUE(rig_->leds()->Drive(first).ok());
  const scan::RawFrame at_zero = *rig_->Snap(camera);
  ASSERT_TRUE(rig_->turntable()->MoveTo(90).ok());
  ASSERT_TRUE(rig_->Snap(camera).ok());  // traces the rays at 90°
  ASSERT_TRUE(rig_->leds()->Drive(second).ok());
  const scan::RawFrame reused = *rig_->Snap(camera);  // from them, under another light
  const scan::RawFrame fresh = *(*fresh_rig)->Snap(*(*fresh_rig)->cameras()[0]);
  EXPECT_EQ(fresh.metadata.rig_state.turntable_deg, 90);
  EXPECT_EQ(reused.pixels, fresh.pixels);
  EXPECT_NE(reused.pixels, at_zero.pixels);
}

// A frame whose rendering the rig's interrupt handler stops (SIGTERM, Ctrl-C) is refused as
// cancelled, not delivered incomplete, and leaves nothing behind: once the interrupt is handled,
// the camera's next frame is the one a camera that was never interrupted takes.
TEST_F(SimBackendsTest, AnInterruptedFrameIsCancelledAndLeavesNothingBehind) {
  Result<std::unique_ptr<Rig>> fresh_rig = MakeRig(kRigYaml);
  ASSERT_TRUE(fresh_rig.ok()) << fresh_rig.status().ToString();
  ASSERT_TRUE((*fresh_rig)->OpenAndConfigure().ok());
  ASSERT_TRUE((*fresh_rig)->StartAll().ok());
  Camera& camera = *rig_->cameras()[0];
  const scan::LedDrive drive[] = {{0, 800}};
  ASSERT_TRUE(rig_->leds()->Drive(drive).ok());
  ASSERT_TRUE(rig_->Snap(camera).ok());             // rays traced and a frame rendered at 0°
  ASSERT_TRUE(rig_->turntable()->MoveTo(90).ok());  // the next needs both anew

  SetInterruptRequested(true);
  const Status interrupted = camera.TriggerSoftware();
  SetInterruptRequested(false);
  EXPECT_EQ(interrupted.code(), StatusCode::kCancelled) << interrupted.ToString();
  EXPECT_NE(interrupted.ToString().find("top"), std::string::npos) << interrupted.ToString();
  EXPECT_EQ(camera.WaitFrame().status().code(), StatusCode::kTimeout);  // nothing delivered

  const scan::RawFrame after = *rig_->Snap(camera);
  const scan::RawFrame fresh = *(*fresh_rig)->Snap(*(*fresh_rig)->cameras()[0]);
  EXPECT_EQ(fresh.metadata.rig_state.turntable_deg, 90);
  EXPECT_EQ(after.pixels, fresh.pixels);
}

TEST_F(SimBackendsTest, FilterWheelColoursTheLight) {
  Camera& camera = *rig_->cameras()[0];
  const scan::LedDrive drive[] = {{1, 1000}};  // the LED behind wheel0
  ASSERT_TRUE(rig_->leds()->Drive(drive).ok());
  FilterWheel& wheel = *rig_->filter_wheels()[0];
  ASSERT_TRUE(wheel.MoveTo(0).ok());  // 450 nm
  const scan::RawFrame blue = *rig_->Snap(camera);
  ASSERT_TRUE(wheel.MoveTo(1).ok());  // 650 nm
  const scan::RawFrame red = *rig_->Snap(camera);
  EXPECT_EQ(red.metadata.rig_state.filter_slots.at("wheel0"), 1);
  // The chart's red patch (row 2, column 2: index 14) is bright through 650 nm, dark through 450.
  // Patch centres lie 4.8 mm apart; camera: 500 mm away, f = 600 px → 1.2 px per mm.
  const double x_mm = (2 - 3 + 0.5) * 4.8, y_mm = (2 - 2 + 0.5) * 4.8;
  const int px = static_cast<int>(std::lround(23.5 + 1.2 * x_mm));
  const int py = static_cast<int>(std::lround(23.5 - 1.2 * y_mm));
  EXPECT_GT(red.at(py, px) - 64, 3 * (blue.at(py, px) - 64)) << red.at(py, px) << " vs " << blue.at(py, px);
}

// hal/device_status.h on real (simulated) devices: what moves ends where it reports, and a
// target that is no slot, no number or on a device that does not move is refused naming it.
TEST_F(SimBackendsTest, DevicesMoveAndDescribeThemselvesAndBadTargetsAreNamed) {
  const Result<std::string> turned = MoveDevice(*rig_->turntable(), 30);
  ASSERT_TRUE(turned.ok()) << turned.status().ToString();
  EXPECT_EQ(*turned, "30 deg");
  EXPECT_NE(DescribeDeviceState(*rig_->turntable())->find("at 30.000 deg"), std::string::npos);
  FilterWheel& wheel = *rig_->filter_wheels()[0];
  EXPECT_EQ(*MoveDevice(wheel, 1), "slot 1");
  for (double bad : {1.5, -1.0, 1e20, static_cast<double>(wheel.slot_count()), std::nan("")}) {
    const Result<std::string> refused = MoveDevice(wheel, bad);
    ASSERT_FALSE(refused.ok()) << bad;
    EXPECT_NE(refused.status().ToString().find(wheel.name()), std::string::npos) << refused.status().ToString();
  }
  EXPECT_EQ(*wheel.Position(), 1);
  const Result<std::string> camera = MoveDevice(*rig_->cameras()[0], 1);
  ASSERT_FALSE(camera.ok());
  EXPECT_NE(camera.status().ToString().find("does not move"), std::string::npos) << camera.status().ToString();
}

// What loom rig list, status and leds print: a line per device, each device's state or why it
// failed, and LEDs that are lit for the hold and switched off by the guard after it.
TEST_F(SimBackendsTest, TheRigListsAndReportsItsDevicesAndHoldsItsLeds) {
  Result<std::unique_ptr<Rig>> closed = MakeRig(kRigYaml);
  ASSERT_TRUE(closed.ok()) << closed.status().ToString();
  Rig& rig = **closed;
  std::ostringstream list, reported, refused, held;
  ListRigDevices(rig, list);
  const std::string listed = list.str();
  EXPECT_EQ(std::count(listed.begin(), listed.end(), '\n'), static_cast<long>(rig.devices().size())) << listed;
  EXPECT_NE(listed.find("turntable"), std::string::npos) << listed;
  EXPECT_EQ(ReportRigStatus(rig, reported), 0) << reported.str();
  EXPECT_NE(reported.str().find("turntable     ok"), std::string::npos) << reported.str();
  // The fixture's rig is running: no device of it can be opened again, and each says so.
  EXPECT_EQ(ReportRigStatus(*rig_, refused), static_cast<int>(rig_->devices().size())) << refused.str();
  EXPECT_NE(refused.str().find("turntable     FAILED"), std::string::npos) << refused.str();
  {
    SafeStateGuard guard(rig);
    ASSERT_TRUE(HoldLeds(rig, {{1, 500}}, 0.05, held).ok());
    EXPECT_EQ(rig.leds()->Read()->current_ma[1], 500);
  }
  EXPECT_NE(held.str().find("1 LEDs on for 0.05 s"), std::string::npos) << held.str();
  EXPECT_EQ(rig.leds()->Read()->current_ma[1], 0);
}

TEST_F(SimBackendsTest, LinearLightAndProjectorLightTheSample) {
  Camera& camera = *rig_->cameras()[0];
  const double dark = MeanDn(*rig_->Snap(camera));
  ASSERT_TRUE(rig_->linear_light()->MoveTo(rig_->linear_light()->travel_mm() / 2).ok());
  ASSERT_TRUE(rig_->linear_light()->SetStrip(true, 1.0).ok());
  const scan::RawFrame strip = *rig_->Snap(camera);
  EXPECT_GT(MeanDn(strip), dark + 20);
  EXPECT_TRUE(strip.metadata.rig_state.linear_light_on);
  ASSERT_TRUE(rig_->linear_light()->SetStrip(false, 0).ok());
  Projector& projector = *rig_->projector();
  EXPECT_EQ(projector.native_width(), 32);  // from the geometry
  ASSERT_TRUE(projector.Show({"white", 32, 24, std::vector<uint8_t>(32 * 24, 255)}).ok());
  const scan::RawFrame white = *rig_->Snap(camera);
  EXPECT_GT(MeanDn(white), dark + 20);
  EXPECT_EQ(white.metadata.rig_state.projector_pattern, "white");
  ASSERT_TRUE(rig_->MakeSafe().ok());  // blanks the projector, strip off
  EXPECT_NEAR(MeanDn(*rig_->Snap(camera)), dark, 1.0);
}

TEST_F(SimBackendsTest, RoiAndMono16) {
  Camera& camera = *rig_->cameras()[0];
  const scan::LedDrive drive[] = {{0, 800}};
  ASSERT_TRUE(rig_->leds()->Drive(drive).ok());
  const scan::RawFrame full = *rig_->Snap(camera);
  ASSERT_TRUE(camera.Stop().ok());
  CameraSettings settings = camera.settings();
  settings.roi = {10, 5, 20, 12};
  settings.pixel_format = scan::PixelFormat::kMono16;
  ASSERT_TRUE(camera.Configure(settings).ok());
  ASSERT_TRUE(camera.Start().ok());
  const scan::RawFrame roi = *rig_->Snap(camera);
  ASSERT_EQ(roi.width, 20);
  ASSERT_EQ(roi.height, 12);
  // Only the window is rendered, with its pixels' own noise and vignetting: the full frame's crop.
  for (int y = 0; y < roi.height; ++y) {
    for (int x = 0; x < roi.width; ++x) {
      ASSERT_EQ(roi.at(y, x), full.at(5 + y, 10 + x) << 4) << "at " << x << "," << y;  // 12-bit values, MSB-aligned
    }
  }
}

// A rig of simulated devices waits virtual time: a wait passes at once, and its clock says so.
TEST_F(SimBackendsTest, ASimulatedRigWaitsVirtualTime) {
  Clock& clock = rig_->clock();
  ASSERT_NE(dynamic_cast<SimClock*>(&clock), nullptr);
  const double before = clock.NowS();
  ASSERT_TRUE(clock.SleepFor(3600).ok());
  EXPECT_DOUBLE_EQ(clock.NowS() - before, 3600);
}

TEST_F(SimBackendsTest, UnknownModelIsNamed) {
  BackendRegistry registry;
  RegisterSimBackends(registry, world_);
  auto doc = ConfigDocument::LoadString("schema_version: 1\nc: {name: side, backend: sim}\n", "x.yaml", 1);
  const ConfigNode node = doc->root().Child("c");
  auto camera = registry.Create<Camera>({"side", "sim", node});
  ASSERT_TRUE(camera.ok());
  const Status opened = (*camera)->Open();
  EXPECT_EQ(opened.code(), StatusCode::kNotFound);
  EXPECT_NE(opened.message().find("no camera 'side'"), std::string::npos) << opened.ToString();
}

// The LED controller's trigger output on the world's trigger line: a pulse exposes every camera on
// hardware trigger once (and no other), at the state then, giving the frame a software trigger
// gives; Rig::Trigger drops what a camera held from earlier pulses.
TEST_F(SimBackendsTest, ATriggerPulseExposesEveryHardwareTriggeredCameraOnce) {
  constexpr char kYaml[] = R"(
cameras:
  - {name: top, backend: sim, supersampling: 1, settings: {pixel_format: Mono12, exposure_us: 20000, trigger: software}}
  - {name: a, model: top, backend: sim, supersampling: 1, settings: {pixel_format: Mono12, exposure_us: 20000, trigger: hardware}}
  - {name: b, model: top, backend: sim, supersampling: 1, settings: {pixel_format: Mono12, exposure_us: 20000, trigger: hardware}}
leds: {name: leds, backend: sim}
trigger: {source: leds}
)";
  rig_.reset();
  auto made = MakeRig(kYaml);
  ASSERT_TRUE(made.ok()) << made.status().ToString();
  Rig& rig = **made;
  ASSERT_EQ(rig.trigger_source(), TriggerSource::kLedController);
  ASSERT_TRUE(rig.OpenAndConfigure().ok());
  ASSERT_TRUE(rig.StartAll().ok());
  Camera& software = *rig.cameras()[0];
  Camera& a = *rig.cameras()[1];
  Camera& b = *rig.cameras()[2];
  EXPECT_EQ(a.WaitFrame().status().code(), StatusCode::kTimeout);  // no pulse, no frame

  const scan::LedDrive drive[] = {{1, 700}};
  ASSERT_TRUE(rig.leds()->Drive(drive).ok());
  const int pulses = world_->trigger_pulses();
  Camera* const all[] = {&software, &a, &b};
  for (const Status& triggered : rig.Trigger(all)) ASSERT_TRUE(triggered.ok()) << triggered.ToString();
  EXPECT_EQ(world_->trigger_pulses(), pulses + 1);  // one pulse for both hardware cameras
  const Result<scan::RawFrame> by_software = software.WaitFrame();
  const Result<scan::RawFrame> by_pulse_a = a.WaitFrame();
  const Result<scan::RawFrame> by_pulse_b = b.WaitFrame();
  ASSERT_TRUE(by_software.ok() && by_pulse_a.ok() && by_pulse_b.ok());
  EXPECT_GT(MeanDn(*by_pulse_a), 150);
  EXPECT_EQ(by_pulse_a->pixels, by_software->pixels);
  EXPECT_EQ(by_pulse_b->pixels, by_software->pixels);
  EXPECT_EQ(software.WaitFrame().status().code(), StatusCode::kTimeout);  // not exposed by the pulse
  EXPECT_EQ(a.WaitFrame().status().code(), StatusCode::kTimeout);         // exposed once

  // Pulses meant for another capture leave frames of the old state in a camera: a snap drops them.
  ASSERT_TRUE(rig.leds()->FireTrigger().ok());
  ASSERT_TRUE(rig.leds()->FireTrigger().ok());
  ASSERT_TRUE(rig.leds()->AllOff().ok());
  const Result<scan::RawFrame> dark = rig.Snap(a);
  ASSERT_TRUE(dark.ok()) << dark.status().ToString();
  EXPECT_NEAR(MeanDn(*dark), 64, 1.0);
  EXPECT_TRUE(dark->metadata.rig_state.leds_on.empty());
  EXPECT_EQ(a.WaitFrame().status().code(), StatusCode::kTimeout);
}

TEST_F(SimBackendsTest, HardwareTriggerWithoutASourceIsRefusedNamingTheCameraOrKey) {
  const Result<std::unique_ptr<Rig>> unpulsed = MakeRig(R"(
cameras: [{name: top, backend: sim, settings: {trigger: hardware}}]
leds: {name: leds, backend: sim}
)");
  ASSERT_FALSE(unpulsed.ok());
  EXPECT_NE(unpulsed.status().ToString().find("camera 'top'"), std::string::npos) << unpulsed.status().ToString();
  EXPECT_NE(unpulsed.status().ToString().find("trigger: {source: leds}"), std::string::npos) << unpulsed.status().ToString();

  const Result<std::unique_ptr<Rig>> no_leds = MakeRig(R"(
cameras: [{name: top, backend: sim, settings: {trigger: hardware}}]
trigger: {source: leds}
)");
  ASSERT_FALSE(no_leds.ok());
  EXPECT_NE(no_leds.status().ToString().find("trigger.source"), std::string::npos) << no_leds.status().ToString();

  const Result<std::unique_ptr<Rig>> unknown = MakeRig(R"(
cameras: [{name: top, backend: sim}]
trigger: {source: lightning}
)");
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.status().ToString().find("trigger.source"), std::string::npos) << unknown.status().ToString();
  EXPECT_NE(unknown.status().ToString().find("lightning"), std::string::npos) << unknown.status().ToString();
}

}  // namespace
}  // namespace loom::hal
