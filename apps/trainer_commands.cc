// The command table of a trainer-only build (LOOM_TRAINER_ONLY: docs/gpu-training.md): `loom
// train` on a machine that has a CUDA LibTorch but not the scanner's other libraries.
#include <torch/cuda.h>
#include <torch/version.h>

#include <iostream>

#include "apps/command.h"
#include "core/version.h"

namespace loom::apps {

const std::vector<Command>& Commands() {
  static const std::vector<Command> commands = {
      {"help", "Show the commands, or one command's options: loom help <command>", RunHelp},
      {"train", "Train the SVBRDF CNN for a rig and preset on simulated materials (this build: train only)", RunTrain},
      {"version", "Print loom's version, LibTorch's and the CUDA GPUs it sees", RunVersion},
  };
  return commands;
}

void StartLibraries(const char*) {}

int RunVersion(int argc, char** argv) {
  CLI::App app("Print loom's version, LibTorch's and the CUDA GPUs it sees", "loom version");
  AddCommonOptions(app);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  std::cout << "loom " << VersionWithCommit() << " (trainer-only build)\n";
  for (const LinkedLibrary& library : CoreLibraries()) {
    std::cout << "  " << library.name << std::string(10 - library.name.size(), ' ') << library.version << "\n";
  }
  std::cout << "  LibTorch  " << TORCH_VERSION << ", CUDA GPUs: " << torch::cuda::device_count() << "\n";
  return kExitOk;
}

}  // namespace loom::apps
