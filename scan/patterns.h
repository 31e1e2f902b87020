#pragma once
// The structured-light patterns a plan names (plan.h: StructuredLightPatterns), as images for
// the projector: "white", "black", "gray_x_BB" (bit BB of the Gray code of the projector column,
// most significant first) and "gray_x_BB_inv", "phase_x_K" (a sinusoid along x with a period of
// 16 columns, shifted by K/steps of a period). Calibration decodes with the same definitions.

#include <string>

#include "core/status.h"
#include "scan/pattern.h"

namespace loom::scan {

inline constexpr int kPhasePeriodColumns = 16;

// Bits of the Gray code that numbers every column of a projector this wide.
int GrayCodeBits(int projector_width);
// "gray_x_BB", or "gray_x_BB_inv" for the inverse.
std::string GrayPatternName(int bit, bool inverse);

// `phase_steps` is the number of phase_x patterns in the sequence.
Result<Pattern> MakePattern(const std::string& name, int width, int height, int phase_steps);

}  // namespace loom::scan
