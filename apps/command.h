#pragma once
// The `loom` binary's command table and the options every command shares.
// A command is a function RunX(argc, argv) where argv[0] is the command's name; it returns an
// exit code: kExitOk, kExitFailure (the work failed; message on stderr) or kExitUsage.

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "core/duration.h"
#include "core/image.h"
#include "core/status.h"
#include "core/version.h"

namespace loom::apps {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitUsage = 2;

struct Command {
  std::string_view name;
  std::string_view summary;  // one line for `loom --help`
  int (*run)(int argc, char** argv);
};

// All commands of this build, in the order `loom --help` lists them (commands.cc; the GPU
// build's: gpu_commands.cc).
const std::vector<Command>& Commands();
// What the build's libraries need before any command runs (main() calls it once).
void StartLibraries(const char* program);
// What `loom version` says of this build: the GPU build's, and the libraries only it links (the
// full build's device and vision libraries; commands.cc or gpu_commands.cc).
struct BuildFacts {
  bool gpu = false;
  std::vector<LinkedLibrary> libraries;
};
BuildFacts ThisBuild();
// A reference normal map for `loom eval` (photos/capture_import.h's rule; the GPU build, which
// reads no photographs, refuses it naming the file).
Result<Image> ReadReferenceNormals(const std::filesystem::path& path, int downsample);
// Adds `loom sim capture` to `sim` and returns what runs it once parsed (sim_capture_command.cc;
// the GPU build's, which writes no photographs, refuses).
std::function<Status()> AddSimCaptureCommand(CLI::App& sim);

// Options every command accepts: --log-level. Call before parsing.
void AddCommonOptions(CLI::App& app);

// --force: an output file may replace a regular file that loom did not write (core/output_file.h's
// rule; a link, device or FIFO is refused even so).
void AddForceOption(CLI::App& app, bool& force);

// Each named output file (option, path; empty paths skipped) checked by core/output_file.h's rule
// before a command's work, so that a refused one leaves nothing written.
Status CheckOutputFiles(const std::vector<std::pair<std::string, std::string>>& outputs, bool force);

// Writes a command's JSON report to a path the user named (none where `path` is empty), with
// "loom_version": its marker under core/output_file.h's rule, which the caller checked before the
// work.
Status WriteJsonReport(const std::string& path, nlohmann::json document);

// Parses argv into `app`. Returns nothing on success; otherwise the exit code to return:
// kExitOk after --help, kExitUsage after a usage error (message on stderr).
std::optional<int> ParseCommandLine(CLI::App& app, int argc, char** argv);

// kExitOk for an ok status; otherwise prints "error: <status>" on stderr and returns kExitFailure.
int ExitCode(const Status& status);

// The commands.
int RunCalibrate(int argc, char** argv);
int RunDemo(int argc, char** argv);
int RunEval(int argc, char** argv);
int RunExport(int argc, char** argv);
int RunFit(int argc, char** argv);
int RunHelp(int argc, char** argv);
int RunImport(int argc, char** argv);
int RunModel(int argc, char** argv);
int RunPlan(int argc, char** argv);
int RunReconstruct(int argc, char** argv);
int RunRig(int argc, char** argv);
int RunScan(int argc, char** argv);
int RunSim(int argc, char** argv);
int RunTrain(int argc, char** argv);
int RunVersion(int argc, char** argv);

}  // namespace loom::apps
