#include "apps/command.h"

#include <cmath>
#include <iostream>

#include "core/log.h"

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
      {"fit", "Fit SVBRDF maps to an observation stack (Ceres, the CNN, or the CNN refined by Ceres)", RunFit},
      {"train", "Train the SVBRDF CNN for a rig and preset on simulated materials", RunTrain},
      {"eval", "Evaluate fitted maps: re-render error, parameter error, an HTML report", RunEval},
      {"export", "Export fitted maps for renderers (glTF with anisotropy)", RunExport},
      {"sim", "The simulator: procedural materials, frames and observation stacks", RunSim},
      {"version", "Print loom's version and the libraries it runs with", RunVersion},
  };
  return commands;
}

void AddCommonOptions(CLI::App& app) {
  app.add_option_function<std::string>(
         "--log-level",
         [](const std::string& name) {
           const Result<LogLevel> level = ParseLogLevel(name);
           if (!level.ok()) throw CLI::ValidationError("--log-level", level.status().message());
           SetLogLevel(*level);
         },
         "Log threshold: debug, info, warning, error, off (default info)")
      ->type_name("LEVEL");
}

std::optional<int> ParseCommandLine(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    std::cout << app.help();
    return kExitOk;
  } catch (const CLI::ParseError& e) {
    std::cerr << "error: " << e.what() << "\n"
              << "Run '" << app.get_name() << " --help' for usage.\n";
    return kExitUsage;
  }
  return std::nullopt;
}

int ExitCode(const Status& status) {
  if (status.ok()) return kExitOk;
  std::cerr << "error: " << status.ToString() << "\n";
  return kExitFailure;
}

}  // namespace loom::apps
