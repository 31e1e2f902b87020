#include "sim/sample.h"

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "sim/fabric.h"
#include "sim/test_materials.h"

namespace loom::sim {

namespace {

// The spec's own values that are out of range: (field, what it must be).
std::vector<std::pair<std::string, std::string>> Problems(const SampleSpec& spec) {
  std::vector<std::pair<std::string, std::string>> problems;
  if (spec.size_px < 8 || spec.size_px > kMaxSampleSide) {
    problems.emplace_back("size_px", "must be in [8, " + std::to_string(kMaxSampleSide) + "]");
  }
  // Below a micrometre a map pixel is nothing a rig resolves, and the heightfield's blur in
  // pixels explodes (a crash once: issue #24).
  if (!(spec.pixel_mm >= 1e-3 && spec.pixel_mm <= 10)) problems.emplace_back("pixel_mm", "must be in [0.001, 10] mm");
  return problems;
}

}  // namespace

Status SampleSpec::Check() const {
  std::vector<std::string> problems;
  for (const auto& [field, problem] : Problems(*this)) problems.push_back(field + " " + problem);
  return ProblemsStatus("sample", problems);
}

SampleSpec ReadSampleSpec(const ConfigNode& node) {
  SampleSpec spec;
  int seed = 0;
  node.Optional("kind", &spec.kind);
  node.Optional("seed", &seed);
  node.Optional("size_px", &spec.size_px);
  node.Optional("pixel_mm", &spec.pixel_mm);
  spec.seed = static_cast<uint64_t>(seed);
  for (const auto& [field, problem] : Problems(spec)) node.AddError(field, problem);
  return spec;
}

Result<Material> MakeSample(const SampleSpec& spec) {
  LOOM_RETURN_IF_ERROR(spec.Check());  // before anything is allocated: a rig's errors are reported later
  const GridOptions grid{spec.size_px, spec.size_px, spec.pixel_mm};
  const double side_mm = spec.size_px * spec.pixel_mm;
  if (spec.kind == "fabric" || spec.kind == "fabric-out-of-model") {
    FabricOptions options;
    options.width_px = options.height_px = spec.size_px;
    options.pixel_mm = spec.pixel_mm;
    return spec.kind == "fabric" ? GenerateFabric(spec.seed, options) : GenerateOutOfModelFabric(spec.seed, options);
  }
  if (spec.kind == "white-tile") return WhiteTile(grid, spec.white.albedo);
  if (spec.kind == "white-tile-on-spacer") {
    if (!(spec.white.spacer_mm > 0)) {
      return InvalidArgumentError("sample kind 'white-tile-on-spacer'", "the rig's white_reference has no spacer_mm");
    }
    return WhiteTileOnSpacer(grid, spec.white.albedo, spec.white.spacer_mm);
  }
  if (spec.kind == "chessboard") return Chessboard(9, 6, side_mm / 14, grid);
  if (spec.kind == "colour-chart") return ColourChart(spec.chart, grid);
  if (spec.kind == "target") {
    if (!spec.target) return InvalidArgumentError("sample kind 'target'", "the rig's geometry has no calibration_target");
    return CalibrationTarget(*spec.target);
  }
  if (spec.kind == "chrome-sphere") return ChromeSphere(spec.probe);
  return InvalidArgumentError("sample kind '" + spec.kind + "'",
                              "unknown (expected fabric, fabric-out-of-model, white-tile, white-tile-on-spacer, chessboard, "
                              "colour-chart, target, chrome-sphere)");
}

}  // namespace loom::sim
