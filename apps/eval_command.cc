// loom eval: fitted maps against the measured stack (re-render L1) and, given one, a reference
// (parameter NRMSE); an HTML report and summary.json.
#include <filesystem>
#include <iomanip>
#include <iostream>

#include "apps/command.h"
#include "core/exr_io.h"
#include "core/observation_stack.h"
#include "fitting/evaluation.h"
#include "fitting/model/svbrdf_maps.h"
#include "fitting/report.h"

namespace loom::apps {
namespace {

namespace fs = std::filesystem;

Result<Image> ReadMaps(const std::string& path) {
  LOOM_ASSIGN_OR_RETURN(ExrImage exr, ReadExr(path));
  if (!fitting::HasSvbrdfLayout(exr.image)) {
    return InvalidArgumentError(path, "not SVBRDF maps: the first channels must be n_s.X ... F0");
  }
  return std::move(exr.image);
}

void PrintSummary(const fitting::Evaluation& e) {
  std::cout << std::fixed << std::setprecision(4);
  if (!e.parameters.empty()) {
    std::cout << "parameter NRMSE against the reference:";
    for (const fitting::ParameterError& p : e.parameters) std::cout << "  " << p.name << " " << p.nrmse;
    std::cout << std::setprecision(2) << "\nshading normal error: median " << e.normal_median_deg << " deg, p90 "
              << e.normal_p90_deg << " deg\n"
              << std::setprecision(4);
  }
  if (!e.map_noise.empty()) {
    std::cout << "map noise (mean squared Laplacian, fit" << (e.parameters.empty() ? "" : " / reference") << "):";
    for (const fitting::MapNoise& n : e.map_noise) {
      std::cout << "  " << n.name << " " << n.fit;
      if (!e.parameters.empty()) std::cout << " / " << n.reference;
    }
    std::cout << "\n";
  }
  std::cout << "re-render relative L1 against the measured values (fit";
  if (!e.reference_vs_measured.empty()) std::cout << " / reference";
  std::cout << "):";
  for (size_t i = 0; i < e.fit_vs_measured.size(); ++i) {
    std::cout << "  " << e.fit_vs_measured[i].group << " " << e.fit_vs_measured[i].relative_l1;
    if (i < e.reference_vs_measured.size()) std::cout << " / " << e.reference_vs_measured[i].relative_l1;
  }
  std::cout << "\n";
}

}  // namespace

int RunEval(int argc, char** argv) {
  CLI::App app("Evaluate fitted SVBRDF maps: re-render error against the stack, parameter error against a reference",
               "loom eval");
  AddCommonOptions(app);
  std::string maps_path, stack_path, reference_path, out, title;
  app.add_option("maps", maps_path, "Fitted maps (svbrdf.exr from loom fit)")->required();
  app.add_option("--stack", stack_path, "The observation stack the maps were fitted to")->required();
  app.add_option("--reference", reference_path, "Reference maps on the same grid (ground truth or another fit)");
  app.add_option("--out", out, "Report directory: index.html, summary.json, PNGs")->required();
  app.add_option("--title", title, "Title of the report");
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;

  Result<Image> maps = ReadMaps(maps_path);
  if (!maps.ok()) return ReportFailure(maps.status());
  Result<ObservationStack> stack = ReadObservationStack(stack_path);
  if (!stack.ok()) return ReportFailure(stack.status());
  std::optional<Image> reference;
  if (!reference_path.empty()) {
    Result<Image> read = ReadMaps(reference_path);
    if (!read.ok()) return ReportFailure(read.status());
    reference = std::move(*read);
  }
  Result<fitting::Evaluation> evaluation = fitting::Evaluate(*maps, reference, *stack);
  if (!evaluation.ok()) return ReportFailure(evaluation.status());
  PrintSummary(*evaluation);
  fitting::ReportInputs inputs{
      title.empty() ? maps_path : title, &*maps, reference ? &*reference : nullptr, &*stack, *evaluation, ""};
  if (Status written = fitting::WriteReport(out, inputs); !written.ok()) return ReportFailure(written);
  std::cout << "report: " << (fs::path(out) / "index.html").string() << "\n";
  return kExitOk;
}

}  // namespace loom::apps
