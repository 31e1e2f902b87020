#pragma once
// Fitted or reference SVBRDF maps read from a file, whichever form it has.

#include <filesystem>

#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting {

// Maps in svbrdf_maps.h's layout read back (svbrdf.exr or a simulator's truth: ReadSvbrdfExr;
// for a FILE.axf, an AxF file's SVBRDF: axf_export.h), with their pixel size when the file
// states it (loom.pixel_mm, AxF's WidthMM; 0 when it does not). A file in another layout is an
// error naming it.
Result<SvbrdfFile> ReadSvbrdf(const std::filesystem::path& path);

}  // namespace loom::fitting
