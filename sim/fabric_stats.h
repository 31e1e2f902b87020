#pragma once
// Histograms of the procedural fabrics' parameters over many seeds: what a CNN trained on them
// has seen (loom sim stats).

#include <cstdint>
#include <map>
#include <ostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace loom::sim {

struct ParameterHistogram {
  std::string name;
  double low = 0, high = 1;  // the bins' range; values beyond it fall in the end bins
  std::vector<int64_t> bins = std::vector<int64_t>(10, 0);
  double min = 1e300, max = -1e300, sum = 0;
  int64_t count = 0;
  void Add(double value);
};

struct FabricStatistics {
  int seeds = 0, size_px = 0;
  std::map<std::string, int> weaves;  // weave name → fabrics
  std::vector<ParameterHistogram> histograms;
  nlohmann::json ToJson() const;
  void Report(std::ostream& out) const;  // one line per parameter, bins in per mille
};

// Fabrics of seeds 0 … seeds − 1, size_px square.
FabricStatistics MeasureFabrics(int seeds, int size_px);

}  // namespace loom::sim
