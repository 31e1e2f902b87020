#pragma once
// Fitted or reference SVBRDF maps read from a file, whichever form it has.

#include <filesystem>
#include <string>

#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting {

// Maps in fitting/model/svbrdf_maps.h's layout read back (svbrdf.exr or a simulator's truth: ReadSvbrdfExr;
// for a FILE.axf, an AxF file's SVBRDF: axf_export.h), with their pixel size when the file
// states it (loom.pixel_mm, AxF's WidthMM; 0 when it does not). A file in another layout is an
// error naming it, and so are values no material has (a parameter not a number but where the
// pixel is NaN in all of them, skipped by a fit; a normal of no direction; a negative albedo; σ
// not positive; F0 outside [0, 1]), each naming its channel and pixel.
Result<SvbrdfFile> ReadSvbrdf(const std::filesystem::path& path);

// OK when `maps` lie on a stack's grid: the same pixels and, where the file states one, the same
// pixel size (maps of another crop or resolution would put each pixel's lobe on another pixel).
// Errors name `what` ("--start FILE").
Status CheckOnStackGrid(const SvbrdfFile& maps, int width, int height, double stack_pixel_mm, const std::string& what);

}  // namespace loom::fitting
