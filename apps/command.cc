#include "apps/command.h"

#include <cmath>
#include <iostream>

#include "core/log.h"
#include "core/output_directory.h"

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
