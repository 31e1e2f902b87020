#pragma once
// A progress line with ETA on stderr: redrawn in place on a terminal, every 10 % otherwise (so
// logs of batch jobs stay short); silent when quiet. Not thread-safe: update from one thread.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

namespace loom {

class ProgressBar {
 public:
  ProgressBar(std::string label, bool quiet);
  ~ProgressBar();  // ends the line on a terminal

  // `detail` follows the counts ("672 frames"); the ETA is the caller's, or extrapolated from
  // the time since construction.
  void Update(int64_t done, int64_t total, const std::string& unit, const std::string& detail = "",
              std::optional<double> eta_s = std::nullopt);

 private:
  std::string label_;
  bool quiet_;
  bool tty_;
  int last_decile_ = -1;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point start_;
};

// A bar per stage of a job whose progress names its stage, labelled `prefix` + the stage's name:
// a stage's first update ends the bar before it and starts its own, whose ETA counts from then.
class StageProgressBars {
 public:
  StageProgressBars(std::string prefix, bool quiet) : prefix_(std::move(prefix)), quiet_(quiet) {}
  void Update(const std::string& stage, int64_t done, int64_t total, const std::string& unit, const std::string& detail = "");
  void Close() { bar_.reset(); }  // ends the bar's line before a report follows

 private:
  std::string prefix_;
  bool quiet_;
  std::string stage_;
  std::optional<ProgressBar> bar_;
};

}  // namespace loom
