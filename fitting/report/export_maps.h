#pragma once
// What `loom export` does with files, for the command and the main job alike: fitted maps
// (svbrdf.exr or an AxF file's SVBRDF) written as glTF 2.0 (gltf_export.h), a MaterialX
// document (mtlx_export.h) and/or an AxF file (fitting/io/axf_export.h). Pixels the fit skipped
// are written black. Every output is checked before any is written (core/output_file.h's rule),
// so one refused leaves nothing half-exported.

#include <filesystem>
#include <iosfwd>

#include "core/status.h"
#include "fitting/report/gltf_export.h"

namespace loom::fitting {

struct ExportRequest {
  std::filesystem::path maps;
  std::filesystem::path gltf, axf, mtlx;  // empty: not written
  double pixel_mm = 0;                    // 0: the maps' loom.pixel_mm attribute
  GltfAnisotropy anisotropy = GltfAnisotropy::kAuto;
  bool force = false;  // the AxF file may replace a regular file loom did not write
};

// Says what it wrote, a line per output, on `report`.
Status ExportMaps(const ExportRequest& request, std::ostream& report);

}  // namespace loom::fitting
