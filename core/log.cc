#include "core/log.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <ctime>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <string>

namespace loom {
namespace {

std::atomic<LogLevel> g_level{LogLevel::kInfo};
std::mutex g_stream_mutex;
std::ostream* g_stream = nullptr;  // guarded by g_stream_mutex; nullptr = std::cerr

char LevelLetter(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug:
      return 'D';
    case LogLevel::kInfo:
      return 'I';
    case LogLevel::kWarning:
      return 'W';
    case LogLevel::kError:
      return 'E';
    case LogLevel::kOff:
      break;
  }
  return '?';
}

std::string_view BaseName(std::string_view path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string_view::npos ? path : path.substr(slash + 1);
}

void WriteTimestamp(std::ostream& out) {
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const auto millis = std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000;
  std::tm local{};
  localtime_r(&seconds, &local);
  out << std::put_time(&local, "%H:%M:%S") << '.' << std::setw(3) << std::setfill('0') << millis;
}

}  // namespace

void SetLogLevel(LogLevel level) { g_level.store(level); }
LogLevel GetLogLevel() { return g_level.load(); }

Result<LogLevel> ParseLogLevel(std::string_view name) {
  std::string lower(name);
  std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (lower == "debug") return LogLevel::kDebug;
  if (lower == "info") return LogLevel::kInfo;
  if (lower == "warning" || lower == "warn") return LogLevel::kWarning;
  if (lower == "error") return LogLevel::kError;
  if (lower == "off") return LogLevel::kOff;
  return InvalidArgumentError("--log-level",
                              "unknown level '" + std::string(name) + "' (expected debug, info, warning, error, off)");
}

void SetLogStream(std::ostream* stream) {
  std::lock_guard lock(g_stream_mutex);
  g_stream = stream;
}

namespace internal {

LogLine::LogLine(LogLevel level, const char* file, int line) : level_(level) {
  stream_ << LevelLetter(level_) << ' ';
  WriteTimestamp(stream_);
  stream_ << ' ' << BaseName(file) << ':' << line << "] ";
}

LogLine::~LogLine() {
  stream_ << '\n';
  std::lock_guard lock(g_stream_mutex);
  std::ostream& out = g_stream ? *g_stream : std::cerr;
  out << stream_.str();
  out.flush();
}

}  // namespace internal
}  // namespace loom
