// loom eval: fitted maps against the measured stack (re-render L1) and, given one, a reference
// (parameter NRMSE); an HTML report and summary.json.
#include <iostream>
#include <optional>

#include "apps/command.h"
#include "core/image.h"
#include "fitting/report/evaluate_directory.h"

namespace loom::apps {
namespace {

struct EvalArgs {
  fitting::EvaluateRequest request;
  std::string reference_normals;
  int normals_downsample = 1;
};

Status Evaluate(EvalArgs args) {
  std::optional<Image> normals;
  if (!args.reference_normals.empty()) {
    LOOM_ASSIGN_OR_RETURN(normals, ReadReferenceNormals(args.reference_normals, args.normals_downsample));
    args.request.reference_normals = &*normals;
    args.request.reference_normals_name = args.reference_normals;
  }
  LOOM_ASSIGN_OR_RETURN(const fitting::EvaluatedDirectory evaluated, fitting::EvaluateToDirectory(args.request));
  evaluated.Report(std::cout);
  return Status::Ok();
}

}  // namespace

int RunEval(int argc, char** argv) {
  CLI::App app("Evaluate fitted SVBRDF maps: re-render error against the stack, parameter error against a reference",
               "loom eval");
  AddCommonOptions(app);
  EvalArgs args;
  app.add_option("maps", args.request.maps, "Fitted maps (svbrdf.exr from loom fit)")->required();
  app.add_option("--stack", args.request.stack, "The observation stack the maps were fitted to")->required();
  app.add_option("--reference", args.request.reference, "Reference maps on the same grid (ground truth or another fit)");
  app.add_option("--out", args.request.out, "Report directory: index.html, summary.json, PNGs")->required();
  app.add_option("--title", args.request.title, "Title of the report");
  app.add_option("--reference-normals", args.reference_normals,
                 "A true normal map (EXR X, Y, Z, or PNG storing (n+1)/2; x right, y up, z towards the camera): the "
                 "angle error, and by true tilt (normals.json)");
  app.add_option("--normals-downsample", args.normals_downsample,
                 "The --downsample the stack was imported with, to bring the normal map to its grid")
      ->check(CLI::Range(1, 64));
  app.add_option("--renderer-views", args.request.renderer_views,
                 "Point-lit views of the fit, rendered by loom, for checking its glTF (OUT/material) in three.js with "
                 "web/render-check.mjs (0: write neither)")
      ->capture_default_str()
      ->check(CLI::Range(0, 64));
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;

  return ExitCode(Evaluate(args));
}

}  // namespace loom::apps
