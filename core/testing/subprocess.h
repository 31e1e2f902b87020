#pragma once
// Subprocess: a child process for tests that need a real peer (a Modbus simulator, a fake GigE
// camera, a `loom scan` to kill -9). stdout is piped so a test can wait for a readiness line;
// stderr is inherited. The destructor kills (SIGKILL) and reaps a child still running.

#include <sys/types.h>

#include <chrono>
#include <string>
#include <vector>

#include "core/status.h"

namespace loom::testing {

class Subprocess {
 public:
  static Result<Subprocess> Start(const std::vector<std::string>& argv);

  Subprocess(Subprocess&& other) noexcept;
  Subprocess& operator=(Subprocess&& other) noexcept;
  ~Subprocess();

  pid_t pid() const { return pid_; }
  // The next line of the child's stdout (without the newline); Timeout if none in time,
  // DataLoss if the child closed stdout.
  Result<std::string> ReadLine(std::chrono::milliseconds timeout);
  void Signal(int signal_number) const;
  // Waits for the child to end; returns its exit code, or 128 + signal.
  int Wait();
  void Kill();

 private:
  Subprocess(pid_t pid, int stdout_fd) : pid_(pid), stdout_fd_(stdout_fd) {}
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  std::string buffer_;
};

// Runs a shell command line to completion: its exit code and stdout and stderr together.
struct CommandResult {
  int exit_code = -1;
  std::string output;
};
CommandResult RunCommand(const std::string& command_line);

}  // namespace loom::testing
