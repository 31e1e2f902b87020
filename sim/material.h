#pragma once
// Materials of the simulator: SVBRDF parameter maps on a regular grid over the sample (the
// top-view frame, x right, y down the image, z up out of the sample; pixel (i, j) covers
// [i, i+1) × [j, j+1) pixels of pixel_mm each, the sample centre at the grid centre) with a
// heightmap in mm. Written to OpenEXR with fitting/model/svbrdf_maps.h's channel names.

#include <cstdint>
#include <filesystem>
#include <string>

#include "core/exr_io.h"
#include "core/image.h"

namespace loom::sim {

struct Material {
  std::string name;          // "fabric twill-3", "white tile", ...
  double pixel_mm = 0.1;     // edge of one map pixel on the sample
  Image maps;                // fitting::kSvbrdfChannels + "height" (mm)
  ExrAttributes provenance;  // how it was made: generator, seed, choices

  int width() const { return maps.width(); }
  int height() const { return maps.height(); }
  double width_mm() const { return maps.width() * pixel_mm; }
  double height_mm() const { return maps.height() * pixel_mm; }
};

// Writes the maps (float, ZIP) with provenance and `loom.pixel_mm`, `loom.units` attributes.
Status WriteMaterial(const Material& material, const std::filesystem::path& path);
// Reads a material written by WriteMaterial (or by a fitter: any SVBRDF map file).
Result<Material> ReadMaterial(const std::filesystem::path& path);

}  // namespace loom::sim
