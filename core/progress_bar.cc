#include "core/progress_bar.h"

#include <unistd.h>

#include <cstdint>
#include <iostream>

#include "core/duration.h"

namespace loom {

ProgressBar::ProgressBar(std::string label, bool quiet)
    : label_(std::move(label)), quiet_(quiet), tty_(::isatty(STDERR_FILENO) != 0), start_(std::chrono::steady_clock::now()) {}

ProgressBar::~ProgressBar() {
  if (tty_ && drawn_) std::cerr << "\n";
}

void ProgressBar::Update(int64_t done, int64_t total, const std::string& unit, const std::string& detail,
                         std::optional<double> eta_s) {
  if (quiet_) return;
  const int percent = total ? static_cast<int>(100 * done / total) : 100;
  if (!tty_ && percent / 10 == last_decile_ && done != total) return;
  if (!tty_ && done == total && last_decile_ == 10) return;
  last_decile_ = percent / 10;
  if (!eta_s) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    eta_s = done > 0 ? elapsed * (total - done) / done : 0.0;
  }
  const int width = 30;
  const int filled = width * percent / 100;
  std::cerr << (tty_ ? "\r" : "") << label_ << " [" << std::string(filled, '=') << std::string(width - filled, ' ') << "] "
            << done << "/" << total << " " << unit << (detail.empty() ? "" : ", " + detail) << ", ETA " << FormatDuration(*eta_s)
            << (tty_ ? "   " : "\n") << std::flush;
  drawn_ = true;
}

void StageProgressBars::Update(const std::string& stage, int64_t done, int64_t total, const std::string& unit,
                               const std::string& detail) {
  if (!bar_ || stage != stage_) {
    bar_.reset();
    bar_.emplace(prefix_ + stage, quiet_);
    stage_ = stage;
  }
  bar_->Update(done, total, unit, detail);
}

}  // namespace loom
