// loom version: the build, its libraries (as each reports itself at run time) and, with
// --devices (always in the GPU build), the devices the CNN can run on.
#include <iostream>

#include "apps/command.h"
#include "core/version.h"
#include "fitting/cnn/cnn_training.h"
#include "fitting/solver_libraries.h"

namespace loom::apps {

int RunVersion(int argc, char** argv) {
  const BuildFacts build = ThisBuild();
  CLI::App app("Print loom's version and the libraries it runs with (for bug reports)", "loom version");
  bool short_form = false;
  app.add_flag("--short", short_form, "Print only loom's version number");
  bool devices = build.gpu;
  app.add_flag("--devices", devices,
               "Also the devices the CNN can run on: the CPU, and the CUDA GPUs its LibTorch sees (loads LibTorch: ~1 s; "
               "the GPU build always lists them)");
  AddCommonOptions(app);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  if (short_form) {
    std::cout << Version() << "\n";
    return kExitOk;
  }
  std::cout << "loom " << VersionWithCommit() << (build.gpu ? " (GPU build: fit, train, model, eval, sim)" : "") << "\n";
  std::vector<LinkedLibrary> libraries = CoreLibraries();
  for (const LinkedLibrary& library : build.libraries) libraries.push_back(library);
  for (const LinkedLibrary& library : fitting::SolverLibraries()) libraries.push_back(library);
  for (const LinkedLibrary& library : libraries) {
    std::cout << "  " << library.name << std::string(10 - library.name.size(), ' ') << library.version << "\n";
  }
  if (!devices) return kExitOk;
  const Result<int> gpus = fitting::CudaDevices();  // the CNN's LibTorch's answer
  std::cout << "  devices   cpu" << (gpus.ok() && *gpus > 0 ? ", " + std::to_string(*gpus) + " CUDA GPU(s)" : "")
            << (gpus.ok() ? "" : " (the CNN's module: " + gpus.status().ToString() + ")") << "\n";
  return kExitOk;
}

}  // namespace loom::apps
