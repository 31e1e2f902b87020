// loom <command> [options]: the one binary. main() only dispatches: every command parses its
// own options (with --help), and every failure ends here with a message and an exit code.
#include <cstring>
#include <iostream>
#include <new>
#include <string>

#include "apps/command.h"
#include "core/check.h"
#include "core/log.h"

namespace {

using loom::apps::Command;
using loom::apps::Commands;

bool IsHelpFlag(const char* arg) { return std::strcmp(arg, "--help") == 0 || std::strcmp(arg, "-h") == 0; }

int Dispatch(int argc, char** argv) {
  int first = 1;
  // Options allowed before the command name: loom --log-level debug scan ...
  while (first < argc && std::strcmp(argv[first], "--log-level") == 0 && first + 1 < argc) {
    const loom::Result<loom::LogLevel> level = loom::ParseLogLevel(argv[first + 1]);
    if (!level.ok()) {
      std::cerr << "error: " << level.status().ToString() << "\n";
      return loom::apps::kExitUsage;
    }
    loom::SetLogLevel(*level);
    first += 2;
  }
  if (first >= argc || IsHelpFlag(argv[first])) {
    char help[] = "help";
    char* help_argv[] = {help};
    const int code = loom::apps::RunHelp(1, help_argv);
    return first >= argc ? loom::apps::kExitUsage : code;
  }
  if (std::strcmp(argv[first], "--version") == 0) {
    char version[] = "version";
    char* version_argv[] = {version};
    return loom::apps::RunVersion(1, version_argv);
  }
  for (const Command& command : Commands()) {
    if (command.name == argv[first]) return command.run(argc - first, argv + first);
  }
  std::cerr << "error: unknown command '" << argv[first] << "'. Run 'loom --help' for the list.\n";
  return loom::apps::kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  loom::apps::StartLibraries(argv[0]);
  try {
    return Dispatch(argc, argv);
  } catch (const std::bad_alloc&) {
    // Sizes are checked before they are allocated (core/memory.h); one that was not ends here,
    // named, rather than as a bare std::bad_alloc.
    std::cerr << "error: out of memory: `loom" << (argc > 1 ? std::string(" ") + argv[1] : std::string())
              << "` asked for more memory than this machine could give (a size or count too large for it?); "
                 "nothing was written\n";
  } catch (const loom::CheckError& e) {
    std::cerr << "internal error (a bug in loom, please report it): " << e.what() << "\n";
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
  }
  return loom::apps::kExitFailure;
}
