#include "fitting/report/evaluation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <map>
#include <string_view>

#include "core/geometry.h"
#include "core/parallel.h"
#include "fitting/model/label.h"
#include "fitting/model/stack_pixels.h"
#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting {
namespace {

struct LabelGroup {
  const char* name;
  int first;
  int count;
  double range;
};
constexpr std::array<LabelGroup, 6> kLabelGroups = {
    {{"a_d", 0, 3, 1}, {"a_s", 3, 3, 1}, {"n_s", 6, 3, 2}, {"sigma", 9, 2, 1}, {"alpha", 11, 2, 2}, {"F0", 13, 1, 1}}};
constexpr size_t kAlphaGroup = 4;
static_assert(std::string_view(kLabelGroups[kAlphaGroup].name) == "alpha");

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * (values.size() - 1))];
}

// A pixel the fit skipped (masked, unseen: fitting writes NaN maps there) is left out of every
// score, for the fit and the reference alike.
bool Fitted(const Image& maps, int x, int y) { return !IsSkippedPixel(maps, x, y); }

void AddParameterErrors(const Image& maps, const Image& reference, Evaluation& evaluation) {
  std::array<double, kLabelGroups.size()> squares{};
  double product_squares = 0;
  double anisotropic_alpha_squares = 0;
  std::vector<double> anisotropic_alpha_deg;
  std::vector<double> normal_deg;
  int pixels = 0;
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) {
      if (!Fitted(maps, x, y) || !Fitted(reference, x, y)) continue;
      ++pixels;
      const WardParams<double> fit = WithSigmaXLarger(GetParams(maps, x, y));
      const WardParams<double> truth = WithSigmaXLarger(GetParams(reference, x, y));
      const Label a = EncodeLabel(fit);
      const Label b = EncodeLabel(truth);
      std::array<double, kLabelGroups.size()> pixel_squares{};
      for (size_t g = 0; g < kLabelGroups.size(); ++g) {
        for (int i = 0; i < kLabelGroups[g].count; ++i) {
          const double d = a[kLabelGroups[g].first + i] - b[kLabelGroups[g].first + i];
          pixel_squares[g] += d * d / kLabelGroups[g].count;
        }
        squares[g] += pixel_squares[g];
      }
      if (truth.sigma_x >= AnisotropicAlphaError::kMinSigmaRatio * truth.sigma_y) {
        anisotropic_alpha_squares += pixel_squares[kAlphaGroup];
        anisotropic_alpha_deg.push_back(RadToDeg(AngleBetweenLobes(fit.alpha, truth.alpha)));
      }
      product_squares += (fit.a_s * fit.f0 - truth.a_s * truth.f0).squaredNorm() / 3;
      normal_deg.push_back(RadToDeg(std::acos(std::clamp(fit.n_s.normalized().dot(truth.n_s.normalized()), -1.0, 1.0))));
    }
  }
  pixels = std::max(pixels, 1);
  for (size_t g = 0; g < kLabelGroups.size(); ++g) {
    evaluation.parameters.push_back({kLabelGroups[g].name, std::sqrt(squares[g] / pixels) / kLabelGroups[g].range});
  }
  evaluation.parameters.push_back({"a_s*F0", std::sqrt(product_squares / pixels)});
  if (const auto anisotropic_pixels = static_cast<double>(anisotropic_alpha_deg.size()); anisotropic_pixels > 0) {
    const auto turned_across = std::ranges::count_if(anisotropic_alpha_deg, [](double deg) { return deg > 45; });
    evaluation.anisotropic_alpha = {std::sqrt(anisotropic_alpha_squares / anisotropic_pixels) / kLabelGroups[kAlphaGroup].range,
                                    anisotropic_pixels / pixels, Percentile(anisotropic_alpha_deg, 0.5),
                                    Percentile(anisotropic_alpha_deg, 0.9),
                                    static_cast<double>(turned_across) / anisotropic_pixels};
  }
  evaluation.normal_median_deg = Percentile(normal_deg, 0.5);
  evaluation.normal_p90_deg = Percentile(normal_deg, 0.9);
}

// Mean squared 4-neighbour Laplacian of a label group's channels over the interior pixels.
double MeanSquaredLaplacian(const Image& maps, const LabelGroup& group) {
  const int w = maps.width(), h = maps.height();
  if (w < 3 || h < 3) return 0;
  std::vector<Label> labels(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) labels[static_cast<size_t>(y) * w + x] = EncodeLabel(WithSigmaXLarger(GetParams(maps, x, y)));
  }
  const auto at = [&](int x, int y, int c) { return labels[static_cast<size_t>(y) * w + x][c]; };
  double sum = 0;
  int64_t counted = 0;
  for (int y = 1; y + 1 < h; ++y) {
    for (int x = 1; x + 1 < w; ++x) {
      if (!Fitted(maps, x, y) || !Fitted(maps, x - 1, y) || !Fitted(maps, x + 1, y) || !Fitted(maps, x, y - 1) ||
          !Fitted(maps, x, y + 1)) {
        continue;
      }
      ++counted;
      for (int c = group.first; c < group.first + group.count; ++c) {
        const double laplacian = at(x - 1, y, c) + at(x + 1, y, c) + at(x, y - 1, c) + at(x, y + 1, c) - 4 * at(x, y, c);
        sum += laplacian * laplacian / group.count;
      }
    }
  }
  return counted ? sum / static_cast<double>(counted) : 0;
}

void AddMapNoise(const Image& maps, const std::optional<Image>& reference, Evaluation& evaluation) {
  for (const LabelGroup& group : kLabelGroups) {
    const std::string name = group.name;
    if (name != "a_s" && name != "sigma" && name != "alpha") continue;
    evaluation.map_noise.push_back(
        {name, MeanSquaredLaplacian(maps, group), reference ? MeanSquaredLaplacian(*reference, group) : 0});
  }
}

// Re-render errors of each of `maps` (fit, reference) in one pass: the observations of a pixel
// (their shadow tests the costly part) are built once for all of them. Rows run in parallel,
// each summed on its own and the rows added in order, so the sums do not depend on the threads.
std::vector<std::vector<RenderError>> RenderErrors(const std::vector<const Image*>& maps, const ObservationStack& stack,
                                                   const StackPixels& pixels) {
  struct Sums {
    double error = 0;
    double measured = 0;
    int64_t values = 0;
  };
  constexpr ObservationGroup kGroups[] = {ObservationGroup::kColour, ObservationGroup::kMonochrome,
                                          ObservationGroup::kLinearLight};
  using GroupSums = std::array<Sums, std::size(kGroups)>;
  const int width = stack.image.width(), height = stack.image.height();
  std::vector<GroupSums> rows(static_cast<size_t>(height) * maps.size());  // [row][maps]
  ParallelFor(height, 0, [&](int y) {
    for (int x = 0; x < width; ++x) {
      if (!std::all_of(maps.begin(), maps.end(), [&](const Image* m) { return Fitted(*m, x, y); })) continue;
      const std::vector<PixelObservation> observations = pixels.Observations(x, y);
      for (size_t m = 0; m < maps.size(); ++m) {
        const WardLobe<double> lobe(GetParams(*maps[m], x, y));
        GroupSums& row = rows[static_cast<size_t>(y) * maps.size() + m];
        for (const PixelObservation& o : observations) {
          Sums& sum = row[static_cast<size_t>(stack.observations[o.source].group)];
          sum.error += std::abs(PredictRadiance(lobe, o) - o.radiance);
          sum.measured += std::abs(o.radiance);
          ++sum.values;
        }
      }
    }
  });
  std::vector<std::vector<RenderError>> errors(maps.size());
  for (size_t m = 0; m < maps.size(); ++m) {
    std::map<std::string, Sums> sums;  // group → sums, "all" included, in name order
    for (int y = 0; y < height; ++y) {
      for (ObservationGroup group : kGroups) {
        const Sums& row = rows[static_cast<size_t>(y) * maps.size() + m][static_cast<size_t>(group)];
        if (row.values == 0) continue;
        for (const std::string& key : {std::string(ObservationGroupName(group)), std::string("all")}) {
          Sums& sum = sums[key];
          sum.error += row.error;
          sum.measured += row.measured;
          sum.values += row.values;
        }
      }
    }
    for (const auto& [group, sum] : sums) {
      errors[m].push_back({group, sum.values, sum.measured > 0 ? sum.error / sum.measured : 0});
    }
  }
  return errors;
}

double AllGroup(const std::vector<RenderError>& errors) {
  for (const RenderError& e : errors) {
    if (e.group == "all") return e.relative_l1;
  }
  return 0;
}

Status CheckGrid(const Image& maps, const ObservationStack& stack, const std::string& what) {
  if (!HasSvbrdfLayout(maps)) return InvalidArgumentError(what, "is not an SVBRDF map image (n_s.X ... F0 first)");
  if (maps.width() != stack.image.width() || maps.height() != stack.image.height()) {
    return InvalidArgumentError(what, std::to_string(maps.width()) + "x" + std::to_string(maps.height()) +
                                          " px does not match the stack's " + std::to_string(stack.image.width()) + "x" +
                                          std::to_string(stack.image.height()));
  }
  return Status::Ok();
}

}  // namespace

Result<NormalComparison> CompareNormals(const Image& maps, const ObservationStack& stack, const Image& reference) {
  LOOM_RETURN_IF_ERROR(CheckGrid(maps, stack, "the fitted maps"));
  if (reference.width() != stack.image.width() || reference.height() != stack.image.height() || reference.num_channels() < 3) {
    return InvalidArgumentError("the reference normals",
                                std::to_string(reference.width()) + "x" + std::to_string(reference.height()) +
                                    " px does not match the stack's " + std::to_string(stack.image.width()) + "x" +
                                    std::to_string(stack.image.height()));
  }
  const StackPixels pixels(stack);
  constexpr int kBands = 9;
  std::vector<double> angles;
  std::array<std::pair<int, double>, kBands> bands{};  // pixels, sum of angles
  for (int y = 0; y < maps.height(); ++y) {
    for (int x = 0; x < maps.width(); ++x) {
      const Eigen::Vector3d truth(reference.at(0, y, x), reference.at(1, y, x), reference.at(2, y, x));
      if (!Fitted(maps, x, y) || !truth.allFinite() || truth.norm() < 0.5) continue;
      const Eigen::Vector3d fit = pixels.LocalFromSample(x, y).transpose() * GetParams(maps, x, y).n_s.normalized();
      const double angle = RadToDeg(std::acos(std::clamp(fit.dot(truth.normalized()), -1.0, 1.0)));
      const double tilt = RadToDeg(std::acos(std::clamp(truth.normalized().z(), -1.0, 1.0)));
      angles.push_back(angle);
      auto& band = bands[std::clamp(static_cast<int>(tilt / 10), 0, kBands - 1)];
      ++band.first, band.second += angle;
    }
  }
  NormalComparison comparison;
  comparison.pixels = static_cast<int>(angles.size());
  if (angles.empty()) return comparison;
  double sum = 0;
  for (double a : angles) sum += a;
  comparison.mean_deg = sum / static_cast<double>(angles.size());
  comparison.median_deg = Percentile(angles, 0.5);
  comparison.p90_deg = Percentile(angles, 0.9);
  for (int b = 0; b < kBands; ++b) {
    if (bands[b].first == 0) continue;
    comparison.bands.push_back({10.0 * b, 10.0 * (b + 1), bands[b].first, bands[b].second / bands[b].first});
  }
  return comparison;
}

nlohmann::json NormalComparison::ToJson() const {
  nlohmann::json by_tilt = nlohmann::json::array();
  for (const Band& b : bands) {
    by_tilt.push_back({{"from_deg", b.from_deg}, {"to_deg", b.to_deg}, {"pixels", b.pixels}, {"mean_deg", b.mean_deg}});
  }
  return {{"pixels", pixels}, {"mean_deg", mean_deg}, {"median_deg", median_deg}, {"p90_deg", p90_deg}, {"by_tilt", by_tilt}};
}

void NormalComparison::Report(std::ostream& out) const {
  out << std::fixed << std::setprecision(2) << "normals against the reference (" << pixels << " px): mean " << mean_deg
      << "°, median " << median_deg << "°, p90 " << p90_deg << "°\n  by true tilt:";
  for (const Band& b : bands) out << " " << b.from_deg << "–" << b.to_deg << "° " << b.mean_deg << " (" << b.pixels << ")";
  out << "\n";
}

double Evaluation::FitL1() const { return AllGroup(fit_vs_measured); }
double Evaluation::ReferenceL1() const { return AllGroup(reference_vs_measured); }

Result<Evaluation> Evaluate(const Image& maps, const std::optional<Image>& reference, const ObservationStack& stack) {
  LOOM_RETURN_IF_ERROR(CheckGrid(maps, stack, "the fitted maps"));
  if (reference) LOOM_RETURN_IF_ERROR(CheckGrid(*reference, stack, "the reference maps"));
  const StackPixels pixels(stack);
  Evaluation evaluation;
  std::vector<const Image*> rendered = {&maps};
  AddMapNoise(maps, reference, evaluation);
  if (reference) {
    AddParameterErrors(maps, *reference, evaluation);
    rendered.push_back(&*reference);
  }
  std::vector<std::vector<RenderError>> errors = RenderErrors(rendered, stack, pixels);
  evaluation.fit_vs_measured = std::move(errors[0]);
  if (reference) evaluation.reference_vs_measured = std::move(errors[1]);
  return evaluation;
}

double MeanObservedRadiance(const ObservationStack& stack, int observation) {
  double sum = 0;
  int64_t n = 0;
  for (float v : stack.image.channel(ObservationStack::ObservationChannel(observation))) {
    if (std::isfinite(v)) sum += v, ++n;
  }
  return n ? sum / static_cast<double>(n) : 0;
}

Image RenderObservations(const Image& maps, const ObservationStack& stack, const std::vector<int>& observations) {
  std::vector<std::string> names;
  for (int k : observations) names.push_back(stack.image.channel_name(ObservationStack::ObservationChannel(k)));
  Image rendered(maps.width(), maps.height(), names);
  for (float& v : std::span<float>(rendered.data(), rendered.pixel_count() * names.size())) v = NAN;
  const StackPixels pixels(stack);
  ParallelFor(maps.height(), 0, [&](int y) {
    for (int x = 0; x < maps.width(); ++x) {
      const WardLobe<double> lobe(GetParams(maps, x, y));
      for (const PixelObservation& o : pixels.Observations(x, y, observations)) {
        const auto slot = std::find(observations.begin(), observations.end(), o.source);
        rendered.at(static_cast<int>(slot - observations.begin()), y, x) = static_cast<float>(PredictRadiance(lobe, o));
      }
    }
  });
  return rendered;
}

void Evaluation::Report(std::ostream& out) const {
  const Evaluation& e = *this;
  out << std::fixed << std::setprecision(4);
  if (!e.parameters.empty()) {
    out << "parameter NRMSE against the reference:";
    for (const ParameterError& p : e.parameters) out << "  " << p.name << " " << p.nrmse;
    if (e.anisotropic_alpha.pixel_share > 0) {
      out << "\nalpha where the reference lobe is anisotropic (sigma_x >= " << std::setprecision(1)
          << AnisotropicAlphaError::kMinSigmaRatio << " sigma_y, " << std::setprecision(0)
          << 100 * e.anisotropic_alpha.pixel_share << " % of the pixels): " << std::setprecision(4) << e.anisotropic_alpha.nrmse
          << std::setprecision(1) << ", angle off by median " << e.anisotropic_alpha.median_deg << " deg, p90 "
          << e.anisotropic_alpha.p90_deg << " deg, over 45 deg at " << 100 * e.anisotropic_alpha.share_over_45_deg
          << " % of them";
    }
    out << std::setprecision(2) << "\nshading normal error: median " << e.normal_median_deg << " deg, p90 " << e.normal_p90_deg
        << " deg\n"
        << std::setprecision(4);
  }
  if (!e.map_noise.empty()) {
    out << "map noise (mean squared Laplacian, fit" << (e.parameters.empty() ? "" : " / reference") << "):";
    for (const MapNoise& n : e.map_noise) {
      out << "  " << n.name << " " << n.fit;
      if (!e.parameters.empty()) out << " / " << n.reference;
    }
    out << "\n";
  }
  out << "re-render relative L1 against the measured values (fit";
  if (!e.reference_vs_measured.empty()) out << " / reference";
  out << "):";
  for (size_t i = 0; i < e.fit_vs_measured.size(); ++i) {
    out << "  " << e.fit_vs_measured[i].group << " " << e.fit_vs_measured[i].relative_l1;
    if (i < e.reference_vs_measured.size()) out << " / " << e.reference_vs_measured[i].relative_l1;
  }
  out << std::defaultfloat << "\n";
}

}  // namespace loom::fitting
