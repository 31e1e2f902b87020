#pragma once
// Export of SVBRDF maps: linear OpenEXR (fitting/model/svbrdf_maps.h's channels, with provenance attributes)
// and PNG previews a person can look at — albedos in sRGB, the shading normal as RGB, σx and σy
// as red and green, α as a hue wheel, height as grey — plus tone-mapped radiance images for
// reports. The renderer-ready glTF export is gltf_export.h; the AxF export is
// fitting/io/axf_export.h.

#include <filesystem>
#include <string>
#include <vector>

#include "core/exr_io.h"
#include "core/image.h"
#include "fitting/io/svbrdf_file.h"

namespace loom::fitting {

// Where fitted maps came from, as svbrdf.exr's attributes say.
struct SvbrdfProvenance {
  std::string method;  // loom fit --method
  std::string stack;   // the observation stack fitted
  std::string rig;
  double pixel_mm = 0;
};

// DIR/svbrdf.exr (the maps, linear, fitting/model/svbrdf_maps.h's channels, with `provenance` and units as
// attributes) and its previews (WriteSvbrdfPreviews); DIR is created.
Status WriteSvbrdf(const std::filesystem::path& dir, const Image& maps, const SvbrdfProvenance& provenance);

// The pixels a fit skipped (IsSkippedPixel) made black and matte (a_d = a_s = 0, the normal up,
// σ 1, α 0, F0 1), for formats that cannot hold NaN: a renderer shows the mask as black. Returns
// how many.
int BlackenSkippedPixels(Image& maps);

// The previews' file names, in the order WriteSvbrdfPreviews writes them (without ".png").
const std::vector<std::string>& SvbrdfPreviewNames();

// DIR/diffuse.png, specular.png, normal.png, sigma.png, alpha.png, height.png (when the maps
// have a height channel). `prefix` goes before each name ("reference-"). Errors name the file.
Status WriteSvbrdfPreviews(const Image& maps, const std::filesystem::path& dir, const std::string& prefix = "");

// One radiance channel as an 8-bit sRGB PNG: `white` maps to 255; NaN is drawn magenta.
Status WriteRadiancePng(const std::filesystem::path& path, const Image& image, int channel, double white);

// Linear sRGB [0, 1] → 8-bit sRGB.
uint8_t ToSrgb8(double linear);

}  // namespace loom::fitting
