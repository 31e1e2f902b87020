#pragma once
// The one logging wrapper of loom. Lines go to stderr (or the stream set by SetLogStream),
// whole lines at a time from any thread:
//
//   LOOM_LOG(Info) << "merged " << n << " exposures for " << frame_name;
//
// Levels: Debug < Info < Warning < Error. `loom --log-level` sets the threshold; the stream
// expression is not evaluated below it. Thread-safe.

#include <ostream>
#include <sstream>
#include <string_view>

#include "core/status.h"

namespace loom {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarning = 2, kError = 3, kOff = 4 };

void SetLogLevel(LogLevel level);
LogLevel GetLogLevel();
// Accepts debug, info, warning, error, off (case-insensitive).
Result<LogLevel> ParseLogLevel(std::string_view name);
// Redirects log lines (nullptr restores stderr). The stream must outlive its use.
void SetLogStream(std::ostream* stream);

inline bool ShouldLog(LogLevel level) { return level >= GetLogLevel(); }

namespace internal {

// Builds one line; the destructor emits it atomically.
class LogLine {
 public:
  LogLine(LogLevel level, const char* file, int line);
  ~LogLine();
  LogLine(const LogLine&) = delete;
  LogLine& operator=(const LogLine&) = delete;
  std::ostream& stream() { return stream_; }

 private:
  LogLevel level_;
  std::ostringstream stream_;
};

}  // namespace internal
}  // namespace loom

// A for-statement rather than if/else: safe inside an unbraced `if` (no dangling else).
#define LOOM_LOG(level)                                                                                                   \
  for (bool loom_log_enabled = ::loom::ShouldLog(::loom::LogLevel::k##level); loom_log_enabled; loom_log_enabled = false) \
  ::loom::internal::LogLine(::loom::LogLevel::k##level, __FILE__, __LINE__).stream()
