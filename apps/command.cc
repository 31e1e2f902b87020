#include "apps/command.h"

#include <cmath>
#include <iostream>

#include "core/file_io.h"
#include "core/log.h"
#include "core/output_directory.h"
#include "core/output_file.h"
#include "core/version.h"

namespace loom::apps {

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

void AddForceOption(CLI::App& app, bool& force) {
  app.add_flag("--force", force, "Replace a regular file at an output path even if loom did not write it");
}

Status CheckOutputFiles(const std::vector<std::pair<std::string, std::string>>& outputs, bool force) {
  for (const auto& [option, path] : outputs) {
    if (!path.empty()) LOOM_RETURN_IF_ERROR(CheckOutputFile(path, option, force));
  }
  return Status::Ok();
}

Status WriteJsonReport(const std::string& path, nlohmann::json document) {
  if (path.empty()) return Status::Ok();
  document["loom_version"] = std::string(VersionWithCommit());
  return WriteFileAtomically(path, document.dump(2) + "\n");
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
  std::cerr << "error: " << OutputDirectory::InUsersTerms(status.ToString()) << "\n";
  return kExitFailure;
}

}  // namespace loom::apps
