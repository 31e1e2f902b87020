#include "sim/fabric_stats.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iomanip>

#include "core/geometry.h"
#include "fitting/model/svbrdf_maps.h"
#include "sim/fabric.h"

namespace loom::sim {

void ParameterHistogram::Add(double value) {
  const int last = static_cast<int>(bins.size()) - 1;
  ++bins[std::clamp(static_cast<int>((value - low) / (high - low) * bins.size()), 0, last)];
  min = std::min(min, value);
  max = std::max(max, value);
  sum += value;
  ++count;
}

FabricStatistics MeasureFabrics(int seeds, int size_px) {
  FabricStatistics stats;
  stats.seeds = seeds;
  stats.size_px = size_px;
  stats.histograms = {{"a_d (mean of RGB)", 0, 1},  {"a_s (mean of RGB)", 0, 1}, {"sigma_x", 0, 1}, {"sigma_y", 0, 1},
                      {"sigma_y / sigma_x", 1, 11}, {"alpha (deg)", -90, 90},    {"F0", 0, 1},      {"n_s tilt (deg)", 0, 45},
                      {"height (mm)", 0, 0.3}};
  FabricOptions options;
  options.width_px = options.height_px = size_px;
  for (int seed = 0; seed < seeds; ++seed) {
    const Material m = GenerateFabric(static_cast<uint64_t>(seed), options);
    ++stats.weaves[std::get<std::string>(m.provenance.at("loom.weave"))];
    const int height = *m.maps.ChannelIndex(fitting::kHeightChannel);
    for (int y = 0; y < m.height(); ++y) {
      for (int x = 0; x < m.width(); ++x) {
        const fitting::WardParams<double> p = fitting::GetParams(m.maps, x, y);
        const double values[] = {
            p.a_d.mean(),           p.a_s.mean(),      p.sigma_x, p.sigma_y,
            p.sigma_y / p.sigma_x,  RadToDeg(p.alpha), p.f0,      RadToDeg(std::acos(std::clamp(p.n_s.z(), -1.0, 1.0))),
            m.maps.at(height, y, x)};
        for (size_t i = 0; i < stats.histograms.size(); ++i) stats.histograms[i].Add(values[i]);
      }
    }
  }
  return stats;
}

nlohmann::json FabricStatistics::ToJson() const {
  nlohmann::json json;
  for (const ParameterHistogram& h : histograms) {
    json[h.name] = {{"min", h.min}, {"max", h.max}, {"mean", h.sum / h.count}, {"range", {h.low, h.high}}, {"bins", h.bins}};
  }
  return json;
}

void FabricStatistics::Report(std::ostream& out) const {
  out << seeds << " fabrics of " << size_px << "x" << size_px << " px; weaves:";
  for (const auto& [weave, count] : weaves) out << " " << weave << " " << count;
  out << "\n" << std::fixed << std::setprecision(3);
  for (const ParameterHistogram& h : histograms) {
    out << "  " << std::left << std::setw(20) << h.name << std::right << " min " << std::setw(8) << h.min << " max "
        << std::setw(8) << h.max << " mean " << std::setw(8) << h.sum / h.count << "  [" << h.low << ".." << h.high << "]:";
    for (int64_t b : h.bins) out << " " << std::setw(4) << (1000 * b + h.count / 2) / h.count;
    out << " per mille\n";
  }
}

}  // namespace loom::sim
