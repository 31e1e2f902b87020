// The full build's command table (the GPU build has gpu_commands.cc instead).
#include "apps/command.h"
#include "calibration/opencv_library.h"
#include "fitting/solve/ceres_failures.h"
#include "hal/aravis/aravis_library.h"
#include "hal/modbus/modbus_library.h"
#include "hal/usb/usb_library.h"
#include "photos/capture_import.h"

namespace loom::apps {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {"help", "Show the commands, or one command's options: loom help <command>", RunHelp},
      {"demo", "The main job on a simulated rig: calibrate, scan, reconstruct, fit, evaluate, summarise", RunDemo},
      {"calibrate", "Calibrate cameras from calibration captures, or check a stored calibration for drift", RunCalibrate},
      {"plan", "Show the measurement plan of a rig and a gloss preset, with its duration", RunPlan},
      {"rig", "Operate a rig's devices: list, status, snap, move, leds", RunRig},
      {"scan", "Run a measurement plan into a crash-safe scan directory, or resume one", RunScan},
      {"reconstruct", "Reconstruct a scan: heightmap and calibrated HDR observation stack in the top view", RunReconstruct},
      {"import", "Import photographs from another rig (photometric stereo, a light dome, flash) as an observation stack",
       RunImport},
      {"fit", "Fit SVBRDF maps to an observation stack (Ceres, the CNN, or the CNN refined by Ceres)", RunFit},
      {"train", "Train the SVBRDF CNN for a rig and preset on simulated materials", RunTrain},
      {"model", "Show a trained CNN (rig, input, width, weights, training), or copy it with float16 weights", RunModel},
      {"eval", "Evaluate fitted maps: re-render error, parameter error, an HTML report", RunEval},
      {"export", "Export fitted maps for renderers (glTF with anisotropy)", RunExport},
      {"sim", "The simulator: procedural materials, frames and observation stacks", RunSim},
      {"version", "Print loom's version and the libraries it runs with", RunVersion},
  };
  return commands;
}

void StartLibraries(const char* program) { fitting::StartCeresLogging(program); }

BuildFacts ThisBuild() {
  return {.libraries = {hal::AravisLibrary(), hal::ModbusLibrary(), hal::UsbLibrary(), calibration::OpenCvLibrary()}};
}

Result<Image> ReadReferenceNormals(const std::filesystem::path& path, int downsample) {
  return photos::ReadNormalMap(path, downsample);
}

}  // namespace loom::apps
