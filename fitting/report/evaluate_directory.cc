#include "fitting/report/evaluate_directory.h"

#include <ostream>
#include <utility>

#include "core/file_io.h"
#include "core/observation_stack.h"
#include "core/output_directory.h"
#include "fitting/io/svbrdf_file.h"
#include "fitting/report/report.h"

namespace loom::fitting {
namespace {

Result<std::optional<Image>> ReadReference(const EvaluateRequest& request, const ObservationStack& stack) {
  if (request.reference.empty()) return std::optional<Image>();
  LOOM_ASSIGN_OR_RETURN(SvbrdfFile read, ReadSvbrdf(request.reference));
  LOOM_RETURN_IF_ERROR(CheckOnStackGrid(read, stack.image.width(), stack.image.height(), stack.pixel_mm,
                                        "--reference " + request.reference.string()));
  return std::optional<Image>(std::move(read.maps));
}

}  // namespace

Result<EvaluatedDirectory> EvaluateToDirectory(const EvaluateRequest& request) {
  LOOM_ASSIGN_OR_RETURN(OutputDirectory report, OutputDirectory::Create(request.out, "--out"));
  LOOM_ASSIGN_OR_RETURN(const SvbrdfFile maps, ReadSvbrdf(request.maps));
  LOOM_ASSIGN_OR_RETURN(const ObservationStack stack, ReadObservationStack(request.stack));
  LOOM_RETURN_IF_ERROR(CheckOnStackGrid(maps, stack.image.width(), stack.image.height(), stack.pixel_mm, request.maps.string()));
  LOOM_ASSIGN_OR_RETURN(const std::optional<Image> reference, ReadReference(request, stack));
  EvaluatedDirectory result;
  LOOM_ASSIGN_OR_RETURN(result.evaluation, Evaluate(maps.maps, reference, stack));
  if (request.reference_normals) {
    Result<NormalComparison> normals = CompareNormals(maps.maps, stack, *request.reference_normals);
    if (!normals.ok()) return normals.status().WithContext("--reference-normals " + request.reference_normals_name);
    result.normals = std::move(*normals);
    LOOM_RETURN_IF_ERROR(WriteFileAtomically(report.partial() / "normals.json", result.normals->ToJson().dump(2) + "\n"));
  }
  const ReportInputs inputs{request.title.empty() ? request.maps.string() : request.title,
                            &maps.maps,
                            reference ? &*reference : nullptr,
                            &stack,
                            result.evaluation,
                            "",
                            request.renderer_views};
  LOOM_RETURN_IF_ERROR(WriteReport(report.partial(), inputs));
  LOOM_RETURN_IF_ERROR(report.Commit());
  result.out = request.out;
  return result;
}

void EvaluatedDirectory::Report(std::ostream& out) const {
  evaluation.Report(out);
  if (normals) normals->Report(out);
  out << "report: " << (this->out / "index.html").string() << "\n";
}

}  // namespace loom::fitting
