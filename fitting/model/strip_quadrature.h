#pragma once
// The linear light as a continuous strip, integrated by Gauss–Legendre quadrature split at the
// BRDF lobe (issue #21, item 3): fewer light samples than the stack's emitters, and nearer the
// continuous strip than they are.
//
// A stack describes a linear-light observation as the strip's `segments` midpoints (equal point
// emitters, equally spaced: core/rig_observation.cc). The radiance a pixel sees is really an
// integral along the strip whose integrand is smooth except under the specular lobe, which can be
// narrower than the emitters' spacing. So, per pixel and observation, the strip is cut into the
// span where the lobe (its exponent, at the parameters given) is within `lobe_fraction` of its
// peak, and the rest either side; each part gets a Gauss–Legendre rule (`lobe_nodes` inside,
// `side_nodes` per side; a part that is absent gives its nodes to the lobe's). Against the
// strip as 4,096 points, on tac7-mini's geometry and fabric parameters (bench_linear_light):
//   32 midpoints (the stack's):      relative error p99 0.22 %,  ÷ the pixel's mean p99 0.36 %, max 1.3 %
//   16 nodes (3 + 10 + 3, default):  relative error p99 0.05 %,  ÷ the pixel's mean p99 0.12 %, max 0.5 %
//   20 nodes (4 + 12 + 4):           relative error p99 0.003 %, ÷ the pixel's mean p99 0.01 %, max 0.2 %
// A shadow or the horizon cutting the strip is placed at the emitters' resolution, as they place it.
// The nodes depend on the lobe: a fit that moves its parameters far from those the nodes were
// placed for must place them again (StripNodesCover tells).
// Thread-safety: pure functions.

#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "core/observation_stack.h"
#include "core/status.h"
#include "fitting/model/observation.h"
#include "fitting/model/ward_gd10.h"

namespace loom::fitting {

struct StripQuadratureOptions {
  int side_nodes = 3;           // Gauss–Legendre nodes for each part of the strip beside the lobe (≥ 1)
  int lobe_nodes = 10;          // for the lobe's span (≥ 1)
  double lobe_fraction = 1e-4;  // the span: where exp(−exponent) ≥ this × its peak along the strip, (0, 1)
  // A fit's lobe has left its nodes when its span at this fraction of its peak is not inside the
  // span they were placed for (at lobe_fraction): a tail below it beside the span is smooth
  // enough for the side nodes. [lobe_fraction, 1).
  double moved_fraction = 1e-2;
  // The span is widened by this fraction of the strip either side of the scanned points within
  // it: a spacing of the stack's 32 emitters, so that a peak between two of them is inside.
  double margin = 1.0 / 32;
  int Nodes() const { return 2 * side_nodes + lobe_nodes; }  // every observation gets exactly this many (< 128)
  Status Check() const;                                      // every problem, naming the field
};

// `nodes` (≥ 5, < 128) nodes per strip, a fifth of them (rounded down) either side of the lobe's
// span: 16 → 3 + 10 + 3, 20 → 4 + 12 + 4.
StripQuadratureOptions StripQuadratureWithNodes(int nodes);

// A straight strip of uniform emitters: from `start_mm` to `end_mm` (sample frame), each mm
// emitting `intensity_per_mm` along `axis` with a cos^falloff_exponent falloff.
struct StripSegment {
  Eigen::Vector3d start_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d end_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis = -Eigen::Vector3d::UnitZ();
  double intensity_per_mm = 0;
  double falloff_exponent = 1;

  Eigen::Vector3d At(double u) const { return start_mm + u * (end_mm - start_mm); }  // u ∈ [0, 1]
  double LengthMm() const { return (end_mm - start_mm).norm(); }
};

// The strip whose midpoints `emitters` are (≥ 2 of them, equal, equally spaced on a line, in
// order), or nothing when they are not such a row.
std::optional<StripSegment> StripOfEmitters(std::span<const PointEmitter> emitters);

// Nodes (in [−1, 1]) and weights (summing to 2) of the n-point Gauss–Legendre rule.
std::vector<std::pair<double, double>> GaussLegendreRule(int n);

// Where along the strip (u ∈ [0, 1], lo ≤ hi) the lobe of `params` seen from `v_local` is within
// `fraction` of its peak: the first and last of the
// points scanned where it is. The points are the stack's emitters, the strip's midpoints
// u_i = (i + ½) / n; `l_local` holds the unit directions towards them in the parameters' frame.
// The whole strip when no point has the lobe above both horizons.
std::pair<double, double> LobeSpan(std::span<const Eigen::Vector3d> l_local, const Eigen::Vector3d& v_local,
                                   const WardParams<double>& params, double fraction);

// The part `lit` of the strip (u from, to) as options.Nodes() point emitters: Gauss–Legendre
// nodes over the lobe's span (widened by options.margin, within `lit`) and the parts of `lit`
// beside it, each emitting intensity_per_mm × the length it stands for.
std::vector<PointEmitter> StripNodes(const StripSegment& strip, std::pair<double, double> lit,
                                     std::pair<double, double> lobe_span, const StripQuadratureOptions& options);

// Whether nodes placed for the lobe span `placed` (at lobe_fraction) still integrate a lobe whose
// span at moved_fraction is `span`.
inline bool StripNodesCover(std::pair<double, double> placed, std::pair<double, double> span,
                            const StripQuadratureOptions& options) {
  return placed.first - options.margin <= span.first && span.second <= placed.second + options.margin;
}

// A light list longer than `count` (a strip's emitters, in order along it) as `count` samples:
// consecutive runs of about equal length merged into one each, at the run's irradiance-weighted
// mean direction with its summed irradiance — the midpoint rule on a coarser partition of the
// strip. Shorter lists come back as they are.
std::vector<LightSample> MergeLightSamples(const std::vector<LightSample>& lights, int count);

}  // namespace loom::fitting
