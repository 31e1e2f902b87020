#pragma once
// Materials with known answers, for calibration captures and for tests of every stage:
//
// | material         | what                                              | used by                      |
// |------------------|---------------------------------------------------|------------------------------|
// | Uniform          | one WardParams everywhere, flat                   | renderer tests (white        |
// |                  |                                                   | Lambertian, uniform glossy)  |
// | WhiteTile        | Lambertian, grey (0.95: a Spectralon-like tile)   | flat field, LED intensities  |
// | WhiteTileOnSpacer| the same, raised on a spacer (its edge a step)    | the projector's focal length |
// | Chessboard       | black/white squares, flat, Lambertian             | geometric calibration        |
// | ColourChart      | the 24 patches of a ColorChecker, Lambertian      | the filters' colour weights  |
// | CalibrationTarget| a chessboard on a wedge (the rig's target model)  | loom calibrate geometry      |
// | ChromeSphere     | a mirror-like sphere resting on the table         | the lights' directions       |
//
// All but the target, the sphere and the raised tile flat (height 0, n_s = z), centred on the sample like every material.

#include "core/rig_model.h"
#include "core/status.h"
#include "fitting/model/ward_gd10.h"
#include "sim/material.h"

namespace loom::sim {

struct GridOptions {
  int width_px = 256;
  int height_px = 256;
  double pixel_mm = 0.5;
  Status Check() const;  // every problem, naming the field (the makers below throw on one)
};

Material UniformMaterial(const std::string& name, const fitting::WardParams<double>& params, const GridOptions& grid);
Material WhiteTile(const GridOptions& grid, double albedo = WhiteReferenceModel{}.albedo);
Material WhiteTileOnSpacer(const GridOptions& grid, double albedo, double spacer_mm);
// A board of (inner_cols + 1) × (inner_rows + 1) squares of square_mm, centred, on white.
Material Chessboard(int inner_cols, int inner_rows, double square_mm, const GridOptions& grid);
// The chart of core/reference_objects.h (its albedos and layout), centred.
Material ColourChart(const ColourChartModel& chart, const GridOptions& grid);
// The rig's target on white, its wedge as heights. Map pixels of 0.1 mm: with tac7-mini's
// target (2.5 mm squares, an even number of them each way, tilt with cos = 0.92) every square
// edge falls on a pixel edge, so the printed corners are exact in the rendered images.
Material CalibrationTarget(const CalibrationTargetModel& target);
// The rig's light probe on a black holder, its upper half as heights (0.05 mm map pixels):
// specular albedo 0.9 with σ 0.05, so an LED's highlight spans a few camera pixels.
Material ChromeSphere(const LightProbeModel& probe);

}  // namespace loom::sim
