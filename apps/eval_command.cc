// loom eval: fitted maps against the measured stack (re-render L1) and, given one, a reference
// (parameter NRMSE); an HTML report and summary.json.
#include <filesystem>
#include <iostream>

#include "apps/command.h"
#include "core/file_io.h"
#include "core/observation_stack.h"
#include "core/output_directory.h"
#include "fitting/report/evaluation.h"
#include "fitting/report/export.h"
#include "fitting/report/report.h"
#include "photos/capture_import.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

struct EvalArgs {
  std::string maps_path, stack_path, reference_path, out, title;
  int renderer_views = 6;
  std::string reference_normals;
  int normals_downsample = 1;
};

// The fit's shading normals against a reference normal map, printed and kept as normals.json.
Status CompareNormals(const EvalArgs& args, const Image& maps, const ObservationStack& stack, const fs::path& report) {
  LOOM_ASSIGN_OR_RETURN(const Image normals, photos::ReadNormalMap(args.reference_normals, args.normals_downsample));
  Result<fitting::NormalComparison> comparison = fitting::CompareNormals(maps, stack, normals);
  if (!comparison.ok()) return comparison.status().WithContext("--reference-normals " + args.reference_normals);
  comparison->Report(std::cout);
  return WriteFileAtomically(report / "normals.json", comparison->ToJson().dump(2) + "\n");
}

Status Evaluate(const EvalArgs& args) {
  const auto& [maps_path, stack_path, reference_path, out, title, renderer_views, reference_normals, normals_downsample] = args;
  LOOM_ASSIGN_OR_RETURN(OutputDirectory report, OutputDirectory::Create(out, "--out"));
  LOOM_ASSIGN_OR_RETURN(const fitting::SvbrdfFile maps, fitting::ReadSvbrdf(maps_path));
  LOOM_ASSIGN_OR_RETURN(const ObservationStack stack, ReadObservationStack(stack_path));
  const int width = stack.image.width(), height = stack.image.height();
  LOOM_RETURN_IF_ERROR(fitting::CheckOnStackGrid(maps, width, height, stack.pixel_mm, maps_path));
  std::optional<Image> reference;
  if (!reference_path.empty()) {
    LOOM_ASSIGN_OR_RETURN(fitting::SvbrdfFile read, fitting::ReadSvbrdf(reference_path));
    LOOM_RETURN_IF_ERROR(fitting::CheckOnStackGrid(read, width, height, stack.pixel_mm, "--reference " + reference_path));
    reference = std::move(read.maps);
  }
  LOOM_ASSIGN_OR_RETURN(const fitting::Evaluation evaluation, fitting::Evaluate(maps.maps, reference, stack));
  evaluation.Report(std::cout);
  if (!reference_normals.empty()) LOOM_RETURN_IF_ERROR(CompareNormals(args, maps.maps, stack, report.partial()));
  const fitting::ReportInputs inputs{
      title.empty() ? maps_path : title, &maps.maps, reference ? &*reference : nullptr, &stack, evaluation, "", renderer_views};
  LOOM_RETURN_IF_ERROR(fitting::WriteReport(report.partial(), inputs));
  LOOM_RETURN_IF_ERROR(report.Commit());
  std::cout << "report: " << (fs::path(out) / "index.html").string() << "\n";
  return Status::Ok();
}

}  // namespace

int RunEval(int argc, char** argv) {
  CLI::App app("Evaluate fitted SVBRDF maps: re-render error against the stack, parameter error against a reference",
               "loom eval");
  AddCommonOptions(app);
  EvalArgs args;
  app.add_option("maps", args.maps_path, "Fitted maps (svbrdf.exr from loom fit)")->required();
  app.add_option("--stack", args.stack_path, "The observation stack the maps were fitted to")->required();
  app.add_option("--reference", args.reference_path, "Reference maps on the same grid (ground truth or another fit)");
  app.add_option("--out", args.out, "Report directory: index.html, summary.json, PNGs")->required();
  app.add_option("--title", args.title, "Title of the report");
  app.add_option("--reference-normals", args.reference_normals,
                 "A true normal map (EXR X, Y, Z, or PNG storing (n+1)/2; x right, y up the image, z towards the camera, "
                 "as photometric-stereo benchmarks give them): the angle error, and by true tilt (normals.json)");
  app.add_option("--normals-downsample", args.normals_downsample,
                 "The --downsample the stack was imported with, to bring the normal map to its grid")
      ->check(CLI::Range(1, 64));
  app.add_option("--renderer-views", args.renderer_views,
                 "Point-lit views of the fit, rendered by loom, for checking its glTF (OUT/material) in three.js with "
                 "web/render-check.mjs (0: write neither)")
      ->capture_default_str()
      ->check(CLI::Range(0, 64));
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;

  return ExitCode(Evaluate(args));
}

}  // namespace loom::apps
