#include "fitting/solve/refine_settings.h"

#include <cmath>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "core/file_io.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

// refine.json's f0 as --f0 takes it: a number, or "material".
Result<std::optional<double>> ParseRefineF0(const nlohmann::json& value, const std::string& what) {
  return ParseFixedF0(value.is_string() ? value.get<std::string>() : value.dump(), what);
}

Status CheckRefineSetting(const fs::path& path, const std::string& key, const nlohmann::json& value) {
  if (key == "retries") {
    return value.is_boolean() ? Status::Ok()
                              : InvalidArgumentError(path.string() + ": " + key, "expected true or false, not " + value.dump());
  }
  if (key == "f0") {
    const Result<std::optional<double>> f0 = ParseRefineF0(value, path.string() + ": " + key);
    return f0.ok() ? Status::Ok() : f0.status();
  }
  const double number = value.is_number() ? value.get<double>() : NAN;
  if (key == "function_tolerance") {
    return number >= 0 && number <= 0.5
               ? Status::Ok()
               : InvalidArgumentError(path.string() + ": " + key, "expected a number in [0, 0.5], not " + value.dump());
  }
  if (key != "smoothing_weight" && key != "smoothing_specular_albedo") {
    return InvalidArgumentError(
        path.string() + ": " + key,
        "unknown key (expected smoothing_weight, smoothing_specular_albedo, retries, function_tolerance, f0 or picked_on)");
  }
  if (!(number >= 0 && number <= 1e6) || (key == "smoothing_specular_albedo" && number == 0)) {
    return InvalidArgumentError(path.string() + ": " + key, "expected a number in [0, 1e6] (a scale > 0), not " + value.dump());
  }
  return Status::Ok();
}

}  // namespace

Status ApplyRefineSettings(const fs::path& model, bool refiner, RefineSettingsGiven given, StackFitOptions& options) {
  const fs::path path = model / kRefineSettingsFile;
  if (!fs::exists(path)) return Status::Ok();
  LOOM_ASSIGN_OR_RETURN(const std::string text, ReadFile(path));
  const nlohmann::json json = nlohmann::json::parse(text, nullptr, false);
  if (json.is_discarded() || !json.is_object()) return InvalidArgumentError(path.string(), "not a JSON object");
  for (const auto& [key, value] : json.items()) {
    if (key == "picked_on") continue;  // how the values were picked, for the reader
    LOOM_RETURN_IF_ERROR(CheckRefineSetting(path, key, value));
  }
  if (!given.smoothing_weight) options.smoothing.weight = json.value("smoothing_weight", options.smoothing.weight);
  options.smoothing.specular_albedo = json.value("smoothing_specular_albedo", options.smoothing.specular_albedo);
  if (refiner && !given.retries) options.retry_poor_fits = json.value("retries", options.retry_poor_fits);
  if (!given.function_tolerance) {
    options.refiner.function_tolerance = json.value("function_tolerance", options.refiner.function_tolerance);
  }
  if (refiner && !given.f0 && json.contains("f0")) {
    LOOM_ASSIGN_OR_RETURN(options.fixed_f0, ParseRefineF0(json["f0"], path.string() + ": f0"));
  }
  return Status::Ok();
}

}  // namespace loom::fitting
