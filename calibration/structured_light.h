#pragma once
// Structured light → heightmap. scan/patterns.h defines what the projector showed: white
// and black references, the Gray code of the projector column bit by bit (each with its
// inverse) and phase-shifted sinusoids along x with a period of kPhasePeriodColumns.
//
// Decoding (per camera pixel): a pixel is usable where white − black shows enough contrast;
// each Gray bit is 1 where the pattern is brighter than its inverse (no threshold to tune, and
// robust to albedo); the code gives the integer column. The phase of the K shifted sinusoids,
// θ = atan2(−Σ I_k sin(2πk/K), Σ I_k cos(2πk/K)), gives the position inside a period; the Gray
// column picks the period. Result: the projector column (subpixel) that lit the pixel.
//
// Triangulation (per pixel of the heightmap grid, in the sample frame at the structured-light
// steps' turntable angle): the height h at which the surface point (x, y, h) lies on the
// projector column that the camera decoded where it sees that point — a 1-D root of
//   f(h) = column_projector(x, y, h) − column_decoded(camera pixel of (x, y, h))
// found by the secant method. Working on the output grid needs no scattered-point
// interpolation, and the camera's and projector's lens models enter exactly. Where no root is
// found (undecodable, occluded) the height is filled from its neighbours and counted.

#include <map>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/rig_model.h"
#include "core/status.h"

namespace loom::calibration {

inline constexpr int kMaxProjectorWidth = 1 << 16;

struct DecodeOptions {
  int projector_width = 0;
  int phase_steps = 4;
  double min_contrast = 0.1;  // white − black, relative to its 90th percentile over the image
  Status Check() const;       // every problem, naming the field
};

// `patterns`: the camera's radiance image (channel 0) for every pattern name of the sequence
// (white, black, gray_x_NN, gray_x_NN_inv, phase_x_K). Returns channel "column" (NaN where
// undecodable). A missing pattern or images of different sizes are errors naming them.
Result<Image> DecodeProjectorColumns(const std::map<std::string, Image>& patterns, const DecodeOptions& options);

struct HeightmapGrid {
  int width = 0;
  int height = 0;
  double pixel_mm = 0;
  double min_height_mm = -5;  // search range of the triangulation
  double max_height_mm = 5;
};

struct TriangulatedHeights {
  std::vector<float> heights_mm;  // row-major on the grid
  int filled = 0;                 // pixels without a root, filled from neighbours
};

// Heights in the sample frame on `grid` (core/heightmap.h's layout) from one camera's decoded
// columns, the structured-light steps taken at `turntable_deg`.
Result<TriangulatedHeights> TriangulateHeights(const Image& columns, const CameraModel& camera, const ProjectorModel& projector,
                                               const TurntableModel& turntable, double turntable_deg, const HeightmapGrid& grid);

}  // namespace loom::calibration
