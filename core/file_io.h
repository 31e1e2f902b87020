#pragma once
// Small durable-file helpers: what "crash-safe" means in loom — a file is either its old
// version or its complete new one, never a mix, and a record appended is on disk when the call
// returns.

#include <filesystem>
#include <string>
#include <string_view>

#include "core/status.h"

namespace loom {

// Writes `text` to a temporary file beside `path`, fsyncs it, renames it into place and fsyncs
// the directory. Errors name `path`.
Status WriteFileAtomically(const std::filesystem::path& path, std::string_view text);

// Appends `line` (a newline is added) to `path` and fsyncs it before returning.
Status AppendLineDurably(const std::filesystem::path& path, std::string_view line);

Result<std::string> ReadFile(const std::filesystem::path& path);

// Creates `directory` and its parents where missing; an error names it.
Status CreateDirectories(const std::filesystem::path& directory);

}  // namespace loom
