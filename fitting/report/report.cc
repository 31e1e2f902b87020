#include "fitting/report/report.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/file_io.h"
#include "core/version.h"
#include "fitting/report/export.h"
#include "fitting/report/gltf_export.h"
#include "fitting/report/mtlx_export.h"
#include "fitting/report/renderer_views.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

std::string Escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '&':
        out += "&amp;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Fixed(double v, int digits) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << v;
  return out.str();
}

// Per group: the observation with the brightest mean (where highlights are) and a typical one.
std::vector<int> ShowcaseObservations(const ObservationStack& stack) {
  std::map<ObservationGroup, std::vector<std::pair<double, int>>> by_group;
  for (size_t k = 0; k < stack.observations.size(); ++k) {
    by_group[stack.observations[k].group].push_back({MeanObservedRadiance(stack, static_cast<int>(k)), static_cast<int>(k)});
  }
  std::vector<int> chosen;
  for (auto& [group, means] : by_group) {
    std::sort(means.begin(), means.end());
    chosen.push_back(means.back().second);
    if (means.size() > 2) chosen.push_back(means[means.size() / 2].second);
  }
  return chosen;
}

// The 99th percentile of what was measured: white in both measured and rendered images.
double White(const Image& image, int channel) {
  std::vector<float> values;
  for (float v : image.channel(channel)) {
    if (std::isfinite(v)) values.push_back(v);
  }
  if (values.empty()) return 1;
  std::sort(values.begin(), values.end());
  return std::max(1e-12f, values[static_cast<size_t>(0.99 * (values.size() - 1))]);
}

std::string ErrorTable(const Evaluation& e) {
  std::ostringstream html;
  if (!e.parameters.empty()) {
    html << "<h2>Parameters against the reference</h2>\n<table><tr><th>parameter</th><th>NRMSE</th></tr>\n";
    for (const ParameterError& p : e.parameters) {
      html << "<tr><td>" << p.name << "</td><td>" << Fixed(p.nrmse, 4) << "</td></tr>\n";
    }
    html << "<tr><td>shading normal angle</td><td>median " << Fixed(e.normal_median_deg, 2) << "°, p90 "
         << Fixed(e.normal_p90_deg, 2) << "°</td></tr></table>\n";
  }
  html << "<h2>Re-rendered against measured (relative L1)</h2>\n<table><tr><th>group</th><th>values</th><th>fit</th>"
       << (e.reference_vs_measured.empty() ? "" : "<th>reference</th>") << "</tr>\n";
  for (size_t i = 0; i < e.fit_vs_measured.size(); ++i) {
    const RenderError& f = e.fit_vs_measured[i];
    html << "<tr><td>" << f.group << "</td><td>" << f.values << "</td><td>" << Fixed(f.relative_l1, 4) << "</td>";
    if (i < e.reference_vs_measured.size()) html << "<td>" << Fixed(e.reference_vs_measured[i].relative_l1, 4) << "</td>";
    html << "</tr>\n";
  }
  html << "</table>\n";
  if (!e.map_noise.empty()) {
    html << "<h2>Map noise (mean squared Laplacian)</h2>\n<table><tr><th>parameter</th><th>fit</th>"
         << (e.parameters.empty() ? "" : "<th>reference</th><th>fit ÷ reference</th>") << "</tr>\n";
    for (const MapNoise& n : e.map_noise) {
      html << "<tr><td>" << n.name << "</td><td>" << Fixed(n.fit, 6) << "</td>";
      if (!e.parameters.empty()) {
        html << "<td>" << Fixed(n.reference, 6) << "</td><td>" << (n.reference > 0 ? Fixed(n.fit / n.reference, 2) : "—")
             << "</td>";
      }
      html << "</tr>\n";
    }
    html << "</table>\n";
  }
  return html.str();
}

Status WriteMapSection(const fs::path& dir, const ReportInputs& in, std::ostringstream& html) {
  LOOM_RETURN_IF_ERROR(WriteSvbrdfPreviews(*in.maps, dir, "fit-"));
  if (in.reference) LOOM_RETURN_IF_ERROR(WriteSvbrdfPreviews(*in.reference, dir, "reference-"));
  html << "<h2>Parameter maps</h2>\n<table><tr><th></th><th>fit</th>" << (in.reference ? "<th>reference</th>" : "") << "</tr>\n";
  for (const std::string& name : SvbrdfPreviewNames()) {
    if (!fs::exists(dir / ("fit-" + name + ".png"))) continue;
    html << "<tr><td>" << name << "</td><td><img src=\"fit-" << name << ".png\"></td>";
    if (in.reference) html << "<td><img src=\"reference-" << name << ".png\"></td>";
    html << "</tr>\n";
  }
  html << "</table>\n";
  return Status::Ok();
}

// The refiner's 1σ maps (unc.*), each with white at its 99th percentile (printed beside it);
// magenta where a parameter is undetermined (NaN).
Status WriteUncertaintySection(const fs::path& dir, const ReportInputs& in, std::ostringstream& html) {
  const std::vector<int> channels = in.maps->ChannelsWithPrefix("unc.");
  if (channels.empty()) return Status::Ok();
  html << "<h2>Uncertainty (1σ of each parameter)</h2>\n<p>From the fit's sandwich covariance (fitting/solve/batch_refiner.h); "
          "black = 0, white = the value given; magenta: not determined by the data.</p>\n<table><tr><th>parameter</th>"
          "<th>1σ</th><th>white at</th></tr>\n";
  for (int channel : channels) {
    const std::string name = in.maps->channel_name(channel);
    const double white = White(*in.maps, channel);
    LOOM_RETURN_IF_ERROR(WriteRadiancePng(dir / (name + ".png"), *in.maps, channel, white));
    html << "<tr><td>" << name.substr(4) << "</td><td><img src=\"" << name << ".png\"></td><td>" << Fixed(white, 4)
         << "</td></tr>\n";
  }
  html << "</table>\n";
  return Status::Ok();
}

Status WriteRenderSection(const fs::path& dir, const ReportInputs& in, std::ostringstream& html) {
  const std::vector<int> shown = ShowcaseObservations(*in.stack);
  const Image rendered = RenderObservations(*in.maps, *in.stack, shown);
  html << "<h2>Measured and re-rendered</h2>\n<p>Same exposure in each pair (white = the measured 99th percentile); "
          "magenta: not used (unseen or in a cast "
          "shadow).</p>\n<table><tr><th>observation</th><th>measured</th><th>fit</th></tr>\n";
  for (size_t i = 0; i < shown.size(); ++i) {
    const int channel = ObservationStack::ObservationChannel(shown[i]);
    const std::string name = in.stack->image.channel_name(channel);
    const double white = White(in.stack->image, channel);
    LOOM_RETURN_IF_ERROR(WriteRadiancePng(dir / (name + "-measured.png"), in.stack->image, channel, white));
    LOOM_RETURN_IF_ERROR(WriteRadiancePng(dir / (name + "-fit.png"), rendered, static_cast<int>(i), white));
    const StackObservation& o = in.stack->observations[shown[i]];
    html << "<tr><td>" << name << " (" << ObservationGroupName(o.group) << ")<br><small>" << Escape(o.description)
         << "</small></td><td><img src=\"" << name << "-measured.png\"></td><td><img src=\"" << name << "-fit.png\"></td></tr>\n";
  }
  html << "</table>\n";
  return Status::Ok();
}

// The glTF and MaterialX exports and the views web/render-check.mjs (three.js),
// web/render-mtlx.mjs (MaterialX's own shader) and blender/render_check.py (Cycles) render;
// web/renderers-page.mjs's renderer/index.html shows them beside loom once they have run.
Status WriteRendererSection(const fs::path& dir, const ReportInputs& in, std::ostringstream& html) {
  if (in.renderer_views <= 0) return Status::Ok();
  LOOM_RETURN_IF_ERROR(WriteGltf(*in.maps, in.stack->pixel_mm, dir / "material").status());
  LOOM_RETURN_IF_ERROR(WriteMaterialX(*in.maps, in.stack->pixel_mm, dir / "mtlx"));
  const std::vector<RendererView> views = ChooseRendererViews(*in.stack, in.renderer_views);
  if (views.empty()) {
    html << "<h2>In a real renderer</h2>\n<p>The fit as glTF 2.0: <a href=\"material/material.gltf\">material/material.gltf</a>. "
            "The stack has no observation lit by a single point light, so there are no views to render it under.</p>\n";
    return Status::Ok();
  }
  LOOM_RETURN_IF_ERROR(WriteRendererViews(dir / "renderer", *in.maps, in.stack->pixel_mm, *in.stack, views));
  html << "<h2>In a real renderer</h2>\n<p>The fit as glTF 2.0: <a href=\"material/material.gltf\">material/material.gltf</a> "
          "(GD10-Ward approximated by glTF's anisotropic GGX, as loom's fitting/report/gltf_export.h states). "
       << views.size()
       << " point-lit views of it, rendered by loom's own model, are in renderer/views.json; "
          "<code>node web/render-check.mjs REPORT</code> renders the glTF under the same lights in three.js (headless "
          "Chromium), <code>node web/render-mtlx.mjs REPORT</code> <a href=\"mtlx/material.mtlx\">the MaterialX "
          "export</a> in the shader MaterialX generates for it, <code>blender -b --python blender/render_check.py -- "
          "REPORT [--gltf]</code> a material built from the MaterialX textures (or the glTF as Blender imports it) in "
          "Blender's Cycles; "
          "<a href=\"renderer/index.html\">renderer/index.html</a> shows them beside loom's rendering with their "
          "relative differences. <code>node web/viewer.mjs REPORT</code> adds "
          "<a href=\"viewer/index.html\">viewer/index.html</a>: the material in three.js under a light that follows "
          "the pointer.</p>\n";
  return Status::Ok();
}

}  // namespace

std::string EvaluationJson(const Evaluation& e) {
  nlohmann::json json;
  for (const ParameterError& p : e.parameters) json["parameter_nrmse"][p.name] = p.nrmse;
  if (!e.parameters.empty()) {
    json["normal_error_deg"] = {{"median", e.normal_median_deg}, {"p90", e.normal_p90_deg}};
    json["alpha_where_anisotropic"] = {{"nrmse", e.anisotropic_alpha.nrmse},
                                       {"pixel_share", e.anisotropic_alpha.pixel_share},
                                       {"angle_error_deg",
                                        {{"median", e.anisotropic_alpha.median_deg},
                                         {"p90", e.anisotropic_alpha.p90_deg},
                                         {"share_over_45", e.anisotropic_alpha.share_over_45_deg}}},
                                       {"min_sigma_ratio", AnisotropicAlphaError::kMinSigmaRatio}};
  }
  for (const MapNoise& n : e.map_noise) {
    json["map_noise"][n.name] = {
        {"fit", n.fit}, {"reference", n.reference}, {"ratio", n.reference > 0 ? n.fit / n.reference : 0.0}};
  }
  for (const RenderError& r : e.fit_vs_measured) {
    json["rerender_l1"]["fit"][r.group] = {{"relative_l1", r.relative_l1}, {"values", r.values}};
  }
  for (const RenderError& r : e.reference_vs_measured) {
    json["rerender_l1"]["reference"][r.group] = {{"relative_l1", r.relative_l1}, {"values", r.values}};
  }
  json["loom_version"] = std::string(VersionWithCommit());
  return json.dump(2) + "\n";
}

Status WriteReport(const fs::path& dir, const ReportInputs& in) {
  LOOM_RETURN_IF_ERROR(CreateDirectories(dir));
  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>loom: " << Escape(in.title) << "</title>\n"
       << "<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}td,th{padding:4px 10px;"
          "border-bottom:1px solid #ccc;text-align:left;vertical-align:top}img{width:192px;image-rendering:pixelated}"
          "</style></head><body>\n<h1>"
       << Escape(in.title) << "</h1>\n"
       << in.notes_html << ErrorTable(in.evaluation);
  LOOM_RETURN_IF_ERROR(WriteMapSection(dir, in, html));
  LOOM_RETURN_IF_ERROR(WriteUncertaintySection(dir, in, html));
  LOOM_RETURN_IF_ERROR(WriteRenderSection(dir, in, html));
  LOOM_RETURN_IF_ERROR(WriteRendererSection(dir, in, html));
  html << "<p><small>" << Escape(std::string(VersionWithCommit())) << "</small></p></body></html>\n";
  LOOM_RETURN_IF_ERROR(WriteFileAtomically(dir / "index.html", html.str()));
  return WriteFileAtomically(dir / "summary.json", EvaluationJson(in.evaluation));
}

namespace {

void PrintEvaluationRow(std::ostream& out, const std::string& method, const nlohmann::ordered_json& e) {
  out << std::left << std::setw(11) << method << std::right << std::fixed << std::setprecision(1) << std::setw(7)
      << e["normal_error_deg"]["median"].get<double>() << std::setw(7) << e["normal_error_deg"]["p90"].get<double>()
      << std::setprecision(3);
  for (const auto& [name, nrmse] : e["parameter_nrmse"].items()) {
    if (name.rfind("n_s", 0) != 0) out << std::setw(9) << nrmse.get<double>();
  }
  out << "  |";
  for (const auto& [group, l1] : e["rerender_l1"]["fit"].items()) out << std::setw(8) << l1["relative_l1"].get<double>();
  out << "  |" << std::setprecision(2);
  for (const auto& [name, noise] : e["map_noise"].items()) out << std::setw(7) << noise["ratio"].get<double>();
  out << std::defaultfloat << "\n";
}

}  // namespace

void PrintEvaluationTable(std::ostream& out, const nlohmann::ordered_json& methods) {
  if (methods.empty()) return;
  const nlohmann::ordered_json& first = methods.begin().value();
  out << "           normal error  parameter NRMSE against the ground truth" << std::string(20, ' ') << "| re-render relative L1"
      << std::string(18, ' ') << "| map noise ÷ truth's\n"
      << std::left << std::setw(11) << "method" << std::right << std::setw(7) << "med°" << std::setw(7) << "p90°";
  for (const auto& [name, nrmse] : first["parameter_nrmse"].items()) {
    if (name.rfind("n_s", 0) != 0) out << std::setw(9) << name;
  }
  out << "  |";
  for (const auto& [group, l1] : first["rerender_l1"]["fit"].items()) out << std::setw(8) << group.substr(0, 7);
  out << "  |";
  for (const auto& [name, noise] : first["map_noise"].items()) out << std::setw(7) << name;
  out << "\n";
  for (const auto& [method, evaluation] : methods.items()) PrintEvaluationRow(out, method, evaluation);
}

}  // namespace loom::fitting
