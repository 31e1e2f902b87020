#include <iostream>

#include "apps/command.h"

namespace loom::apps {
namespace {

void PrintOverview(std::ostream& out) {
  out << "loom: scan materials and fit spatially varying BRDFs\n\n"
      << "Usage: loom [--log-level LEVEL] <command> [options]\n\n"
      << "Commands:\n";
  for (const Command& command : Commands()) {
    out << "  " << command.name << std::string(12 - command.name.size(), ' ') << command.summary << "\n";
  }
  out << "\nEvery command takes --help. Exit codes: 0 ok, 1 failure, 2 usage error.\n";
}

}  // namespace

int RunHelp(int argc, char** argv) {
  CLI::App app("Show the commands, or one command's options", "loom help");
  std::string topic;
  app.add_option("command", topic, "The command to describe");
  AddCommonOptions(app);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  if (topic.empty()) {
    PrintOverview(std::cout);
    return kExitOk;
  }
  for (const Command& command : Commands()) {
    if (command.name == topic) {
      char help_flag[] = "--help";
      char* help_argv[] = {const_cast<char*>(command.name.data()), help_flag};
      return command.run(2, help_argv);
    }
  }
  std::cerr << "error: unknown command '" << topic << "'\n";
  PrintOverview(std::cerr);
  return kExitUsage;
}

}  // namespace loom::apps
