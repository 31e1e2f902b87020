#pragma once
// What `loom eval` does with files, for the command and the main job alike: fitted maps against
// the stack they were fitted to (re-render L1) and, given one, a reference on its grid (parameter
// NRMSE) and a true normal map (angle error by tilt, normals.json); the HTML report and
// summary.json written into a new directory, whole or not at all.

#include <filesystem>
#include <iosfwd>
#include <optional>
#include <string>

#include "core/image.h"
#include "core/status.h"
#include "fitting/report/evaluation.h"

namespace loom::fitting {

struct EvaluateRequest {
  std::filesystem::path maps;  // svbrdf.exr
  std::filesystem::path stack;
  std::filesystem::path reference;  // empty: none
  std::filesystem::path out;
  std::string title;                         // empty: the maps' path
  int renderer_views = 6;                    // point-lit views rendered for checking the export (0: none)
  const Image* reference_normals = nullptr;  // on the stack's grid; none: no angle error
  std::string reference_normals_name;        // names it in errors
};

struct EvaluatedDirectory {
  Evaluation evaluation;
  std::optional<NormalComparison> normals;
  std::filesystem::path out;

  // What `loom eval` prints: the evaluation, the normals' comparison, where the report is.
  void Report(std::ostream& out) const;
};

Result<EvaluatedDirectory> EvaluateToDirectory(const EvaluateRequest& request);

}  // namespace loom::fitting
