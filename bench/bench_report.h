#pragma once
// Runs the Google Benchmarks registered in a bench binary, prints them as usual and writes one
// machine-readable JSON file with every result and the ratios that matter (e.g. batched vs
// naive evaluation), all measured in the same run:
//
//   bench_brdf --json=brdf.json [--benchmark_filter=... and other Google Benchmark flags]
//
// JSON: {"bench": ..., "description": ..., "cpu_cores": N, "results": [{"name", "real_time_ns",
//        "iterations", "items_per_second", "bytes_per_second", counters...}], "ratios": {...}}

#include <string>
#include <vector>

namespace loom::bench {

// ratio `name` = items_per_second of `numerator` / items_per_second of `denominator`
// (or bytes_per_second when the benchmarks report bytes only).
struct Ratio {
  std::string name;
  std::string numerator;
  std::string denominator;
};

int RunBenchmarks(int argc, char** argv, const std::string& bench_name, const std::string& description,
                  const std::vector<Ratio>& ratios);

}  // namespace loom::bench
