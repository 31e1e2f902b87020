#pragma once
// Photographs from other rigs as an observation stack (core/observation_stack.h): `loom import`.
//
// Layouts, detected from the files (ImportOptions::layout forces one):
// | layout | files                                                            | lights, camera                 |
// |--------|------------------------------------------------------------------|--------------------------------|
// | ps     | filenames.txt (one image a line), light_directions.txt ("x y z" | directional (x right, y up, z  |
// |        | a line, unit), light_intensities.txt ("r g b": divided out),     | towards the camera); an        |
// |        | mask.png (optional; non-zero = the object)                       | orthographic camera down −z    |
// | lp     | one *.lp file: the image count, then "IMAGE x y z" a line        | directional, as ps; intensity 1|
// | flash  | images NN.png (or .jpg, .exr) rectified to the sample plane,     | point lights and cameras at    |
// |        | camera_pos.txt and light_pos.txt ("x,y,z" cm a line: sample      | the given positions; the flash |
// |        | frame, z up, y up the image), image_size.txt (the sample's width | isotropic, light_power.txt its |
// |        | in cm), light_power.txt ("r,g,b"); or capture.json with          | intensity per channel          |
// |        | camera_pos, light_pos, image_size (and light_power)              |                                |
//
// The image's grid is kept: stack pixel (i, j) is image pixel (column i, row j), or its N × N
// block with --downsample N (the mean of its seen values). The stack frame has y down the image,
// so every direction and position given with y up enters with y negated. Each RGB image is
// three observations (one per channel, colour weights (1,0,0), (0,1,0), (0,0,1)); a grey one is
// one (weights 1/3 each). Unseen values are NaN: outside the mask, and at the top of the
// encoding's range (clipped). A block with a clipped value is unseen in that channel: its mean
// lies above its seen values' by an unknown amount, and near a highlight, where clipped values
// gather, the seen ones' mean reads it darker than it is. Radiance is the decoded value divided
// by the light's intensity, times the scale (below).
//
// Errors name the file: a missing light file, counts that do not match, an image of another size
// or bit depth (1-, 2- and 4-bit PNGs are refused), a mask of another size.

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/observation_stack.h"
#include "core/status.h"

namespace loom::photos {

enum class Layout { kPhotometricStereo, kLightPositions, kFlash };
std::string_view LayoutName(Layout layout);  // "ps", "lp", "flash"
// A layout by name; an unknown one is an error naming `what` (the option) and the layouts.
Result<Layout> ParseLayout(const std::string& name, const std::string& what);

// How stored values map to linear radiance (before the scale): linear, the sRGB curve, or a
// power (value^gamma).
struct Encoding {
  enum class Kind { kLinear, kSrgb, kGamma } kind = Kind::kLinear;
  double gamma = 1;
  std::string Name() const;  // "linear", "srgb", "gamma:2.2"
};
// "linear", "srgb" or "gamma:G" (G in (0, 10]); an error naming `what` otherwise.
Result<Encoding> ParseEncoding(const std::string& text, const std::string& what);
// "X,Y,Z" in cm (a flash's offset from the lens); an error naming `what` otherwise.
Result<Eigen::Vector3d> ParseFlashOffset(const std::string& text, const std::string& what);

struct ImportOptions {
  std::optional<Layout> layout;      // unset: detected from the files
  std::optional<Encoding> encoding;  // unset: 16-bit PNG and EXR linear, 8-bit sRGB; flash gamma 2.2
  int downsample = 1;                // N × N blocks of image pixels per stack pixel
  // Radiance scale. Unset: automatic, so that albedos stay inside the model's bound
  // (AutomaticScale): 1 unless the images are too bright for it.
  std::optional<double> scale;
  // ps and lp: the size of an image pixel in mm (their files do not state one; only shadows
  // and the maps' physical size depend on it).
  double pixel_mm = 0.1;
  // flash: where the flash sits relative to the position light_pos gives (cm, sample frame, y up
  // the image), added to every light position. Unset, where every light is at its camera (the
  // files say nothing of the offset): estimated from the highlights (EstimateFlashOffset in
  // capture_import.cc) and reported; give 0,0,0 to keep the files' positions.
  std::optional<Eigen::Vector3d> flash_offset_cm;
  // Set: image k (0-based, in the layout's order) is left out of the stack and kept apart
  // (ImportResult::held_out), for scoring a fit on a view it never saw.
  std::optional<int> hold_out;
  int threads = 0;       // 0: one per core
  Status Check() const;  // every problem, naming the field
};

struct ImportResult {
  ObservationStack stack;
  std::optional<ObservationStack> held_out;  // with ImportOptions::hold_out: that image's observations
  Layout layout = Layout::kFlash;
  Encoding encoding;
  int images = 0;
  int masked_pixels = 0;  // stack pixels with no seen value
  int64_t clipped_values = 0;
  double scale = 1;
  bool scale_automatic = false;
  std::optional<Eigen::Vector3d> flash_offset_cm;  // flash: the offset applied (cm, y up)
  int flash_offset_images = 0;                     // of which images' highlights it was estimated (0: given)
  double seconds = 0;
  nlohmann::json ToJson() const;
  void Report(std::ostream& out) const;  // two lines for the operator
};

Result<ImportResult> ImportCapture(const std::filesystem::path& dir, const ImportOptions& options = {});

// A reference normal map in the photometric-stereo convention (x right, y up the image, z
// towards the camera): an EXR with channels X, Y, Z (or R, G, B), or an 8- or 16-bit PNG storing
// (n + 1)/2 (a zero pixel: no normal). Returned as channels X, Y, Z in the stack frame (y
// negated) on the grid `loom import --downsample N` makes (N × N block means, renormalised);
// NaN where there is none.
Result<Image> ReadNormalMap(const std::filesystem::path& path, int downsample = 1);

// The layout a folder's files say it is; an error listing what each layout needs when none fits.
Result<Layout> DetectLayout(const std::filesystem::path& dir);

// The automatic scale: the albedo a Lambertian surface would need for each pixel's brighter
// observations (its 90th percentile of π L / E, E the irradiance at normal incidence: highlights
// above it are left out) is taken at the 99th percentile over the pixels; where that exceeds
// kAlbedoTarget, the scale brings it there, else 1 (the images' own scale is kept).
inline constexpr double kAlbedoTarget = 0.8;
double AutomaticScale(const ObservationStack& stack, int threads);

}  // namespace loom::photos
