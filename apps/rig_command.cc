// loom rig list | status | snap | move | leds: operate a rig's devices one at a time, e.g. to
// check the wiring of a new scanner or to recalibrate by hand. Every subcommand holds a
// safe-state guard: LEDs go off and motion stops when it ends, Ctrl-C included.
#include <iostream>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "apps/backends.h"
#include "apps/command.h"
#include "core/file_io.h"
#include "core/output_file.h"
#include "hal/aravis/aravis_backend.h"
#include "hal/device_status.h"
#include "hal/rig.h"
#include "scan/frame.h"

namespace loom::apps {
namespace {

using hal::Rig;

int List(const std::string& rig_path, bool discover) {
  if (!rig_path.empty()) {
    Result<LoadedRig> loaded = LoadRig(rig_path);
    if (!loaded.ok()) return ExitCode(loaded.status());
    std::cout << "rig '" << loaded->rig->name() << "' (" << rig_path << "): " << loaded->rig->devices().size() << " devices"
              << (loaded->sim ? ", simulated" : "") << "\n";
    hal::ListRigDevices(*loaded->rig, std::cout);
  }
  if (discover) {
    const std::vector<hal::DiscoveredCamera> cameras = hal::DiscoverAravisCameras();
    std::cout << "cameras found by Aravis discovery: " << cameras.size() << "\n";
    hal::ListDiscoveredCameras(cameras, std::cout);
  }
  return kExitOk;
}

Status WriteFrame(const scan::RawFrame& frame, const std::string& path) {
  if (path.ends_with(".png")) {
    const cv::Mat image(frame.height, frame.width, CV_16UC1, const_cast<uint16_t*>(frame.pixels.data()));
    // Encoded in memory and written through a temporary file: the PNG appears only whole.
    std::vector<uchar> png;
    if (!cv::imencode(".png", image, png)) return IoError(path, "cannot encode PNG");
    return WriteFileAtomically(path,
                               MarkPngAsLoomOutput(std::string_view(reinterpret_cast<const char*>(png.data()), png.size())));
  }
  if (!path.ends_with(".exr")) return InvalidArgumentError("--out " + path, "must end in .exr or .png");
  return scan::WriteFrameExr(frame, path);
}

Status Snap(Rig& rig, const std::string& camera, double exposure_us, const std::string& leds, const std::string& out,
            bool force) {
  LOOM_RETURN_IF_ERROR(CheckOutputFile(out, "--out", force));
  std::vector<scan::LedDrive> drives;
  if (!leds.empty()) {
    LOOM_ASSIGN_OR_RETURN(drives, scan::ParseLedDrives(leds, "--leds"));
  }
  hal::SafeStateGuard guard(rig);
  LOOM_ASSIGN_OR_RETURN(const scan::RawFrame frame, hal::SnapFrame(rig, camera, exposure_us, drives));
  LOOM_RETURN_IF_ERROR(WriteFrame(frame, out));
  std::cout << "wrote " << out << ": " << frame.width << "x" << frame.height << " "
            << scan::PixelFormatName(frame.metadata.pixel_format) << ", exposure " << frame.metadata.exposure_us << " us, from "
            << camera << "\n";
  return rig.FindDevice(camera)->Close();  // the LEDs stay open for the guard to switch off
}

Status Move(Rig& rig, const std::string& name, double to) {
  LOOM_ASSIGN_OR_RETURN(hal::Device* const device, hal::FindNamedDevice(rig, name));
  hal::SafeStateGuard guard(rig);
  LOOM_RETURN_IF_ERROR(rig.OpenAndConfigure(device));
  LOOM_RETURN_IF_ERROR(device->Start());
  LOOM_ASSIGN_OR_RETURN(const std::string where, hal::MoveDevice(*device, to));
  std::cout << device->name() << " is at " << where << "\n";
  return device->Close();
}

Status Leds(Rig& rig, const std::string& on, double hold_s) {
  LOOM_ASSIGN_OR_RETURN(const std::vector<scan::LedDrive> leds, scan::ParseLedDrives(on, "--on"));
  hal::SafeStateGuard guard(rig);
  return hal::HoldLeds(rig, leds, hold_s, std::cout);
}

// --rig, which every subcommand takes.
CLI::Option* AddRigOption(CLI::App& app, std::string& rig_path) {
  return app.add_option("--rig", rig_path, "Rig YAML, or its name in configs/rig/");
}

}  // namespace

int RunRig(int argc, char** argv) {
  CLI::App app("Operate a rig's devices one at a time: list, status, snap, move, leds", "loom rig");
  AddCommonOptions(app);
  app.require_subcommand(1);
  std::string rig_path;
  bool discover = false;
  CLI::App* list = app.add_subcommand("list", "List the rig's devices (and, with --discover, the cameras on the network)");
  AddRigOption(*list, rig_path);
  list->add_flag("--discover", discover, "Broadcast GigE Vision discovery on every network interface");
  CLI::App* status = app.add_subcommand("status", "Open every device and print what it reports");
  AddRigOption(*status, rig_path)->required();
  std::string camera;
  std::string out;
  double exposure_us = 0;
  CLI::App* snap = app.add_subcommand("snap", "Capture one frame from a camera to EXR (float DN) or 16-bit PNG");
  AddRigOption(*snap, rig_path)->required();
  snap->add_option("--camera", camera, "Camera name in the rig")->required();
  snap->add_option("--out", out, "Output file, .exr or .png")->required();
  bool force = false;
  AddForceOption(*snap, force);
  snap->add_option("--exposure-us", exposure_us, "Exposure (default, or 0: the rig's setting)")->check(CLI::Range(0.0, 1e8));
  std::string snap_leds;
  snap->add_option("--leds", snap_leds, "Light these LEDs for the frame: LED:MILLIAMPS[,...]");
  std::string device;
  double to = 0;
  CLI::App* move = app.add_subcommand("move", "Move the turntable (deg), the linear light (mm) or a filter wheel (slot)");
  AddRigOption(*move, rig_path)->required();
  move->add_option("--device", device, "Device name in the rig")->required();
  move->add_option("--to", to, "Target: degrees, mm or slot")->required();
  std::string on;
  double hold_s = 5;
  CLI::App* leds = app.add_subcommand("leds", "Light LEDs for a while, then switch them off");
  AddRigOption(*leds, rig_path)->required();
  leds->add_option("--on", on, "LED:MILLIAMPS[,LED:MILLIAMPS...], LEDs numbered from 0")->required();
  leds->add_option("--hold-s", hold_s, "Seconds to keep them on (default 5)")->check(CLI::NonNegativeNumber);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;

  if (*list) {
    if (rig_path.empty() && !discover) {
      std::cerr << "error: loom rig list needs --rig FILE or --discover\n";
      return kExitUsage;
    }
    return List(rig_path, discover);
  }
  Result<LoadedRig> loaded = LoadRig(rig_path);
  if (!loaded.ok()) return ExitCode(loaded.status());
  Rig& rig = *loaded->rig;
  if (*status) return hal::ReportRigStatus(rig, std::cout) == 0 ? kExitOk : kExitFailure;
  Status done;
  if (*snap) done = Snap(rig, camera, exposure_us, snap_leds, out, force);
  if (*move) done = Move(rig, device, to);
  if (*leds) done = Leds(rig, on, hold_s);
  return ExitCode(done);
}

}  // namespace loom::apps
