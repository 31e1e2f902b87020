#pragma once
// Small durable-file helpers: what "crash-safe" means in loom — a file is either its old
// version or its complete new one, never a mix, and a record appended is on disk when the call
// returns.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/status.h"

namespace loom {

// The output rule for a file: `path` may be new or a regular file (which the write replaces); a
// symbolic link (even to a regular file), directory, device, FIFO or socket there is refused, as
// renaming over it would replace the link or the device node itself. Errors name `path`.
Status CheckReplaceableFile(const std::filesystem::path& path);

// The same rule for an output folder: `path` may be new, a directory or a regular file (which the
// caller judges); a symbolic link, device, FIFO or socket is refused. `what` names the option
// ("--out") in the error.
Status CheckDirectoryOutputPath(const std::filesystem::path& path, const std::string& what);

// Where a command writes more than one output: each output's folder exists, so that the first is
// not written when a later one cannot be. Errors name `what` (the option) and the path.
Status CheckOutputFolderExists(const std::filesystem::path& path, const std::string& what);

// Writes `text` to a temporary file beside `path`, fsyncs it, renames it into place and fsyncs
// the directory. Errors name `path`; CheckReplaceableFile's rule holds.
Status WriteFileAtomically(const std::filesystem::path& path, std::string_view text);

// Appends `line` (a newline is added) to `path` and fsyncs it before returning.
Status AppendLineDurably(const std::filesystem::path& path, std::string_view line);

// A regular file's whole text; a device or FIFO (which can read without end) or a file over
// `max_bytes` is refused, naming it.
Result<std::string> ReadFile(const std::filesystem::path& path, uintmax_t max_bytes = uintmax_t{1} << 30);

// Creates `directory` and its parents where missing; an error names it.
Status CreateDirectories(const std::filesystem::path& directory);

}  // namespace loom
