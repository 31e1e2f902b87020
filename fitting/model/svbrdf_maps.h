#pragma once
// SVBRDF parameter maps: one WardParams per pixel of the sample's top-view frame, stored as an
// Image (and in OpenEXR) with these channel names — the contract between sim (ground truth),
// the fitters (their output) and evaluation/export.
//
// | channel            | meaning                                         | unit       |
// |--------------------|-------------------------------------------------|------------|
// | n_s.X, n_s.Y, n_s.Z| shading normal in the local geometric frame     | unit vector|
// | a_d.R, a_d.G, a_d.B| diffuse albedo (linear sRGB primaries)          | [0, 1]     |
// | a_s.R, a_s.G, a_s.B| specular albedo                                 | [0, 1]     |
// | sigma_x, sigma_y   | roughness along t and b                         | [1e-3, 1]  |
// | alpha              | anisotropy angle                                | rad        |
// | F0                 | Schlick reflectance at normal incidence         | [0, 1]     |
// | height             | surface height above the sample plane (optional)| mm         |
//
// A pixel NaN in every parameter is one a fit skipped (IsSkippedPixel): it has no material.
//
// The local geometric frame of a pixel: z = geometric normal (of the heightmap as structured
// light resolves it), x = the sample frame's x axis made orthogonal to z.

#include <array>
#include <filesystem>
#include <string>

#include "core/image.h"
#include "core/status.h"
#include "fitting/model/ward_gd10.h"

namespace loom::fitting {

inline constexpr std::array<const char*, kNumWardParams> kSvbrdfChannels = {
    "n_s.X", "n_s.Y", "n_s.Z", "a_d.R", "a_d.G", "a_d.B", "a_s.R", "a_s.G", "a_s.B", "sigma_x", "sigma_y", "alpha", "F0"};
inline constexpr const char* kHeightChannel = "height";

// An image with the 13 parameter channels (and `height` when `with_height`), zero-filled.
Image MakeSvbrdfImage(int width, int height, bool with_height);

// The parameters at a pixel. The channels must be at the indices MakeSvbrdfImage puts them
// (CHECKed once by HasSvbrdfLayout()).
WardParams<double> GetParams(const Image& maps, int x, int y);
void SetParams(Image& maps, int x, int y, const WardParams<double>& params);

// True if the first 13 channels are kSvbrdfChannels in order.
bool HasSvbrdfLayout(const Image& maps);

// A pixel that a fit skipped (masked, unseen, too few usable observations) is NaN in all 13
// parameters; every reader of maps leaves it out (evaluation, export, previews).
bool IsSkippedPixel(const Image& maps, int x, int y);

// Maps in this layout as an OpenEXR file holds them (svbrdf.exr, a simulator's truth), with their
// pixel size when the file states it (loom.pixel_mm; 0 when it does not). A file in another
// layout is an error naming it.
struct SvbrdfFile {
  Image maps;
  double pixel_mm = 0;
};
Result<SvbrdfFile> ReadSvbrdfExr(const std::filesystem::path& path);

}  // namespace loom::fitting
