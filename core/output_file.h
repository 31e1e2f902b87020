#pragma once
// The output rule for a file a user names (`loom import … --out STACK.exr`, `--json REPORT`,
// `export --axf FILE`): loom creates it, or replaces a regular file that loom wrote, which its
// format's marker shows; a regular file loom did not write is refused unless the user says
// `--force`, and a link, device, FIFO or socket is refused always (CheckReplaceableFile). Files
// inside an output directory follow the directory's rule (core/output_directory.h) instead.
//
// The markers, one per format loom writes to a user's path:
//   EXR   an attribute named "loom…" (every WriteExr records loomChannelOrder)
//   JSON  a top-level object with "loom_version"
//   PNG   a tEXt chunk "Software" whose text begins "loom" (MarkPngAsLoomOutput)
//   text  a first line beginning with kLoomTextMarker (YAML files)
//   AxF   its own test, passed by the caller (fitting/io/axf_export.h)

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

#include "core/status.h"

namespace loom {

inline constexpr std::string_view kLoomTextMarker = "# written by loom";

using LoomOutputTest = std::function<bool(const std::filesystem::path&)>;

// Whether `path` carries one of the markers above (AxF's aside). Unreadable files carry none.
bool HasLoomMarker(const std::filesystem::path& path);

// `path` may be new, or a regular file that `written_by_loom` recognises (or any regular file
// when `force`). Errors name `what` (the option) and the path, and say how to go on.
Status CheckOutputFile(const std::filesystem::path& path, const std::string& what, bool force,
                       const LoomOutputTest& written_by_loom = HasLoomMarker);

// `png` (an encoded PNG) with a tEXt chunk "Software" = "loom VERSION" after its header.
std::string MarkPngAsLoomOutput(std::string_view png);

}  // namespace loom
