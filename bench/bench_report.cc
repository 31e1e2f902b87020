#include "bench/bench_report.h"

#include <benchmark/benchmark.h>

#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <thread>

namespace loom::bench {
namespace {

struct Result {
  double real_time_ns = 0;
  int64_t iterations = 0;
  std::map<std::string, double> counters;
};

// Prints like the console reporter and keeps every run for the JSON file.
class CollectingReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      if (run.error_occurred) continue;
      Result& result = results_[run.benchmark_name()];
      result.iterations = run.iterations;
      result.real_time_ns = run.GetAdjustedRealTime() * UnitToNanoseconds(run.time_unit);
      for (const auto& [name, counter] : run.counters) result.counters[name] = counter.value;
    }
    ConsoleReporter::ReportRuns(runs);
  }
  const std::map<std::string, Result>& results() const { return results_; }

 private:
  static double UnitToNanoseconds(benchmark::TimeUnit unit) {
    switch (unit) {
      case benchmark::kNanosecond:
        return 1;
      case benchmark::kMicrosecond:
        return 1e3;
      case benchmark::kMillisecond:
        return 1e6;
      case benchmark::kSecond:
        return 1e9;
    }
    return 1;
  }
  std::map<std::string, Result> results_;
};

double Rate(const Result& result) {
  for (const char* key : {"items_per_second", "bytes_per_second"}) {
    if (auto it = result.counters.find(key); it != result.counters.end()) return it->second;
  }
  return 0;
}

}  // namespace

int RunBenchmarks(int argc, char** argv, const std::string& bench_name, const std::string& description,
                  const std::vector<Ratio>& ratios) {
  std::string json_path = bench_name + ".json";
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    if (std::strncmp(argv[i], "--json=", 7) == 0) {
      json_path = argv[i] + 7;
    } else {
      args.push_back(argv[i]);
    }
  }
  int benchmark_argc = static_cast<int>(args.size());
  benchmark::Initialize(&benchmark_argc, args.data());
  if (benchmark::ReportUnrecognizedArguments(benchmark_argc, args.data())) return 2;
  CollectingReporter reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();

  nlohmann::json out;
  out["bench"] = bench_name;
  out["description"] = description;
  out["cpu_cores"] = std::thread::hardware_concurrency();
  out["results"] = nlohmann::json::array();
  for (const auto& [name, result] : reporter.results()) {
    nlohmann::json entry = {{"name", name}, {"real_time_ns", result.real_time_ns}, {"iterations", result.iterations}};
    for (const auto& [counter, value] : result.counters) entry[counter] = value;
    out["results"].push_back(entry);
  }
  out["ratios"] = nlohmann::json::object();
  for (const Ratio& ratio : ratios) {
    const auto a = reporter.results().find(ratio.numerator);
    const auto b = reporter.results().find(ratio.denominator);
    if (a == reporter.results().end() || b == reporter.results().end() || Rate(b->second) == 0) {
      continue;  // filtered out in this run
    }
    out["ratios"][ratio.name] = Rate(a->second) / Rate(b->second);
  }
  std::ofstream file(json_path);
  file << out.dump(2) << "\n";
  if (!file) {
    std::cerr << "error: cannot write " << json_path << "\n";
    return 1;
  }
  std::cout << "wrote " << json_path << "\n";
  return 0;
}

}  // namespace loom::bench
