#pragma once
// The evaluation report people look at: DIR/index.html (self-contained but for its PNGs) with
// the error tables, the fitted parameter maps beside the reference's, and measured beside
// re-rendered images for a few observations of each group (the brightest — where highlights
// are — and a typical one); DIR/summary.json with the same numbers for scripts. Optionally the
// material as glTF with views for checking it in another renderer (ReportInputs::renderer_views).

#include <filesystem>
#include <optional>
#include <ostream>
#include <string>

#include <nlohmann/json.hpp>

#include "core/image.h"
#include "core/observation_stack.h"
#include "fitting/report/evaluation.h"

namespace loom::fitting {

struct ReportInputs {
  std::string title;  // "fabric:1 on tac7-mini"
  const Image* maps = nullptr;
  const Image* reference = nullptr;  // optional
  const ObservationStack* stack = nullptr;
  Evaluation evaluation;
  std::string notes_html;  // extra lines (timings, fit summary), already escaped
  // > 0: the maps as glTF in DIR/material/ (gltf_export.h) and this many views of them in
  // DIR/renderer/ (renderer_views.h), which web/render-check.mjs renders in three.js.
  int renderer_views = 0;
};

Status WriteReport(const std::filesystem::path& dir, const ReportInputs& inputs);

// The evaluation as JSON (the report's summary.json).
std::string EvaluationJson(const Evaluation& evaluation);

// Several methods' evaluations (their summary.json documents by method name, in order) side by
// side for a terminal: normal error, parameter NRMSE, re-render L1 per group, map noise.
void PrintEvaluationTable(std::ostream& out, const nlohmann::ordered_json& methods);

}  // namespace loom::fitting
