// The command table of the GPU build (LOOM_GPU_BUILD: docs/gpu-training.md): training, fitting
// and evaluating on a machine that has a CUDA LibTorch but not the scanner's other libraries.
#include "apps/command.h"
#include "fitting/solve/ceres_failures.h"

namespace loom::apps {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {"help", "Show the commands, or one command's options: loom help <command>", RunHelp},
      {"fit", "Fit SVBRDF maps to an observation stack (Ceres, the CNN, or the CNN refined by Ceres)", RunFit},
      {"train", "Train the SVBRDF CNN for a rig and preset on simulated materials", RunTrain},
      {"model", "Show a trained CNN (rig, input, width, weights, training), or copy it with float16 weights", RunModel},
      {"eval", "Evaluate fitted maps: re-render error, parameter error, an HTML report", RunEval},
      {"sim", "The simulator: procedural materials, frames and observation stacks", RunSim},
      {"version", "Print loom's version, its libraries and the CUDA GPUs its LibTorch sees", RunVersion},
  };
  return commands;
}

void StartLibraries(const char* program) { fitting::StartCeresLogging(program); }

BuildFacts ThisBuild() { return {.gpu = true}; }

Result<Image> ReadReferenceNormals(const std::filesystem::path& path, int) {
  return UnimplementedError(path.string(),
                            "the GPU build reads no normal maps (it has no image codecs): evaluate with a full build");
}

std::function<Status()> AddSimCaptureCommand(CLI::App& sim) {
  sim.add_subcommand("capture", "Photographs as other rigs take them (not in the GPU build)")->allow_extras();
  return [] {
    return UnimplementedError("loom sim capture",
                              "the GPU build writes no photographs (it has no image codecs): use a full build");
  };
}

}  // namespace loom::apps
