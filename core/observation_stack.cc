#include "core/observation_stack.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/check.h"
#include "core/exr_io.h"
#include "core/geometry.h"
#include "core/version.h"

namespace loom {
namespace {

using Json = nlohmann::json;

constexpr const char* kTableAttribute = "loom.observation_table";

Json VectorJson(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

Eigen::Vector3d VectorFromJson(const Json& j, const std::string& key) {
  if (!j.is_array() || j.size() != 3) throw std::invalid_argument(key + " must be [x, y, z]");
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

ObservationGroup ParseGroup(const std::string& name) {
  if (std::optional<ObservationGroup> group = ObservationGroupFromName(name)) return *group;
  throw std::invalid_argument("group '" + name + "' is not colour, monochrome or linear");
}

const Json& Key(const Json& entry, const std::string& key) {
  if (!entry.contains(key)) throw std::invalid_argument("missing key '" + key + "'");
  return entry.at(key);
}

StackObservation ObservationFromJson(const Json& entry) {
  static const std::set<std::string> kKeys = {"group",       "camera",      "camera_mm", "turntable_deg",
                                              "rgb_weights", "description", "emitters",  "view_direction"};
  for (const auto& [key, value] : entry.items()) {
    if (!kKeys.contains(key)) throw std::invalid_argument("unknown key '" + key + "'");
  }
  StackObservation o;
  o.group = ParseGroup(Key(entry, "group").get<std::string>());
  o.camera = Key(entry, "camera").get<std::string>();
  o.camera_mm = VectorFromJson(Key(entry, "camera_mm"), "camera_mm");
  o.turntable_deg = Key(entry, "turntable_deg").get<double>();
  o.rgb_weights = VectorFromJson(Key(entry, "rgb_weights"), "rgb_weights");
  o.description = Key(entry, "description").get<std::string>();
  if (entry.contains("view_direction")) {
    o.view_direction = VectorFromJson(entry.at("view_direction"), "view_direction");
    if (std::abs(o.view_direction->norm() - 1) > 1e-6) throw std::invalid_argument("view_direction is not a unit vector");
  }
  if (!o.view_direction && !(o.camera_mm.z() > 0)) {
    throw std::invalid_argument("camera_mm must lie above the sample plane (z > 0): a camera at or below it sees no pixel");
  }
  if (Key(entry, "emitters").size() > kMaxEmittersPerObservation) {
    throw std::invalid_argument("an observation has " + std::to_string(Key(entry, "emitters").size()) +
                                " emitters, more than the " + std::to_string(kMaxEmittersPerObservation) +
                                " loom fits (every pixel's prediction sums over them)");
  }
  for (const Json& e : Key(entry, "emitters")) {
    // [x, y, z, axis x, axis y, axis z, intensity, falloff exponent]: compact, because a linear
    // light observation has one emitter per strip segment. At infinity: [lx, ly, lz, E], the unit
    // direction towards the light and its irradiance.
    if (e.is_array() && e.size() == 4) {
      const Eigen::Vector3d towards(e[0].get<double>(), e[1].get<double>(), e[2].get<double>());
      if (std::abs(towards.norm() - 1) > 1e-6)
        throw std::invalid_argument("a directional emitter's direction is not a unit vector");
      const double irradiance = e[3].get<double>();
      if (!(std::isfinite(irradiance) && irradiance >= 0)) {
        throw std::invalid_argument("a directional emitter's irradiance must be finite and ≥ 0");
      }
      o.emitters.push_back(PointEmitter::AtInfinity(towards, irradiance));
      continue;
    }
    if (!e.is_array() || e.size() != 8) {
      throw std::invalid_argument("an emitter must be [x, y, z, ax, ay, az, I, n] or, at infinity, [lx, ly, lz, E]");
    }
    PointEmitter emitter;
    emitter.position_mm = {e[0].get<double>(), e[1].get<double>(), e[2].get<double>()};
    emitter.axis = Eigen::Vector3d(e[3].get<double>(), e[4].get<double>(), e[5].get<double>());
    if (std::abs(emitter.axis.norm() - 1) > 1e-6) throw std::invalid_argument("an emitter axis is not a unit vector");
    emitter.intensity = e[6].get<double>();
    emitter.falloff_exponent = e[7].get<double>();
    o.emitters.push_back(emitter);
  }
  return o;
}

Status CheckFinite(const Image& image, int channel, bool allow_nan, const std::string& file) {
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      const float v = image.at(channel, y, x);
      if (std::isinf(v) || (!allow_nan && std::isnan(v))) {
        return DataLossError(file, "channel " + image.channel_name(channel) + " holds " + std::to_string(v) + " at pixel (" +
                                       std::to_string(x) + ", " + std::to_string(y) + ")");
      }
    }
  }
  return Status::Ok();
}

// The geometric normals are directions: a zero or scaled one is a damaged file, which every
// fitter would otherwise meet deep inside a worker thread.
Status CheckUnitNormals(const ObservationStack& stack, const std::string& file) {
  constexpr float kTolerance = 1e-2f;
  for (int y = 0; y < stack.image.height(); ++y) {
    for (int x = 0; x < stack.image.width(); ++x) {
      const float length = static_cast<float>(stack.Normal(x, y).norm());
      if (!(std::abs(length - 1) <= kTolerance)) {
        return DataLossError(file, "the geometric normal at pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                       ") has length " + std::to_string(length) + ", not 1");
      }
    }
  }
  return Status::Ok();
}

}  // namespace

std::string_view ObservationGroupName(ObservationGroup group) {
  switch (group) {
    case ObservationGroup::kColour:
      return "colour";
    case ObservationGroup::kMonochrome:
      return "monochrome";
    case ObservationGroup::kLinearLight:
      return "linear";
  }
  return "?";
}

std::optional<ObservationGroup> ObservationGroupFromName(std::string_view name) {
  for (ObservationGroup group : {ObservationGroup::kColour, ObservationGroup::kMonochrome, ObservationGroup::kLinearLight}) {
    if (ObservationGroupName(group) == name) return group;
  }
  return std::nullopt;
}

double PointEmitter::IntensityTowards(const Eigen::Vector3d& p_in_sample) const {
  return IntensityAlong((p_in_sample - position_mm).normalized());
}

PointEmitter PointEmitter::AtInfinity(const Eigen::Vector3d& towards_light, double irradiance) {
  PointEmitter e;
  e.axis = -towards_light;
  e.intensity = irradiance;
  e.at_infinity = true;
  return e;
}

double PointEmitter::IrradianceAt(const Eigen::Vector3d& p_in_sample) const {
  if (at_infinity) return intensity;
  return IntensityTowards(p_in_sample) / (position_mm - p_in_sample).squaredNorm();
}

Eigen::Vector3d ObservationStack::Position(int x, int y) const {
  return {image.at(0, y, x), image.at(1, y, x), image.at(2, y, x)};
}

Eigen::Vector3d ObservationStack::Normal(int x, int y) const { return {image.at(3, y, x), image.at(4, y, x), image.at(5, y, x)}; }

std::vector<std::string> StackChannelNames(size_t observations) {
  std::vector<std::string> names = {"pos.X", "pos.Y", "pos.Z", "normal.X", "normal.Y", "normal.Z"};
  for (size_t i = 0; i < observations; ++i) {
    std::ostringstream name;
    name << "obs" << std::setw(4) << std::setfill('0') << i;
    names.push_back(name.str());
  }
  return names;
}

ObservationStack MakeObservationStack(int width, int height, double pixel_mm, std::vector<StackObservation> observations) {
  ObservationStack stack;
  stack.image = Image(width, height, StackChannelNames(observations.size()));
  const auto normal_z = stack.image.channel(5);
  std::fill(normal_z.begin(), normal_z.end(), 1.0f);
  stack.pixel_mm = pixel_mm;
  stack.observations = std::move(observations);
  return stack;
}

ObservationStack EveryNthPixel(const ObservationStack& stack, int n) {
  LOOM_CHECK(n >= 1) << "every n-th pixel needs n ≥ 1, not " << n;
  const int width = (stack.image.width() + n - 1) / n, height = (stack.image.height() + n - 1) / n;
  ObservationStack every = MakeObservationStack(width, height, stack.pixel_mm * n, stack.observations);
  every.rig = stack.rig;
  every.source = stack.source;
  for (int c = 0; c < stack.image.num_channels(); ++c) {
    for (int j = 0; j < height; ++j) {
      for (int i = 0; i < width; ++i) every.image.at(c, j, i) = stack.image.at(c, j * n, i * n);
    }
  }
  return every;
}

ObservationStack SelectObservations(const ObservationStack& stack, const std::vector<int>& keep) {
  std::vector<StackObservation> table;
  for (int k : keep) table.push_back(stack.observations.at(k));
  ObservationStack selected = MakeObservationStack(stack.image.width(), stack.image.height(), stack.pixel_mm, std::move(table));
  selected.rig = stack.rig;
  selected.source = stack.source;
  for (int c = 0; c < kStackGeometryChannels; ++c) {
    std::copy(stack.image.channel(c).begin(), stack.image.channel(c).end(), selected.image.channel(c).begin());
  }
  for (size_t i = 0; i < keep.size(); ++i) {
    const auto from = stack.image.channel(ObservationStack::ObservationChannel(keep[i]));
    std::copy(from.begin(), from.end(),
              selected.image.channel(ObservationStack::ObservationChannel(static_cast<int>(i))).begin());
  }
  return selected;
}

std::string ObservationTableToJson(const std::vector<StackObservation>& observations) {
  Json table = Json::array();
  for (const StackObservation& o : observations) {
    Json emitters = Json::array();
    for (const PointEmitter& e : o.emitters) {
      if (e.at_infinity) {
        emitters.push_back({-e.axis.x(), -e.axis.y(), -e.axis.z(), e.intensity});
        continue;
      }
      emitters.push_back({e.position_mm.x(), e.position_mm.y(), e.position_mm.z(), e.axis.x(), e.axis.y(), e.axis.z(),
                          e.intensity, e.falloff_exponent});
    }
    Json entry = {{"group", ObservationGroupName(o.group)},
                  {"camera", o.camera},
                  {"camera_mm", VectorJson(o.camera_mm)},
                  {"turntable_deg", o.turntable_deg},
                  {"rgb_weights", VectorJson(o.rgb_weights)},
                  {"description", o.description},
                  {"emitters", emitters}};
    if (o.view_direction) entry["view_direction"] = VectorJson(*o.view_direction);
    table.push_back(std::move(entry));
  }
  return table.dump();
}

Result<std::vector<StackObservation>> ParseObservationTable(const std::string& json, const std::string& source) {
  Json table;
  try {
    table = Json::parse(json);
  } catch (const Json::exception& e) {
    return DataLossError(source, std::string("the observation table is not JSON: ") + e.what());
  }
  if (!table.is_array()) return DataLossError(source, "the observation table must be a JSON array");
  std::vector<StackObservation> observations;
  for (size_t i = 0; i < table.size(); ++i) {
    try {
      observations.push_back(ObservationFromJson(table[i]));
    } catch (const std::exception& e) {
      return DataLossError(source, "observation table entry " + std::to_string(i) + ": " + e.what());
    }
  }
  return observations;
}

Status WriteObservationStack(const std::filesystem::path& path, const ObservationStack& stack) {
  LOOM_CHECK(stack.image.channel_names() == StackChannelNames(stack.observations.size()))
      << "stack channels do not match its " << stack.observations.size() << " observations";
  return WriteExr(path, stack.image,
                  {{"loom.kind", std::string("observation stack")},
                   {"loom.source", stack.source},
                   {"loom.rig", stack.rig},
                   {"loom.pixel_mm", stack.pixel_mm},
                   {"loom.units", std::string("pos mm (sample frame); obs radiance; NaN = not seen")},
                   {kTableAttribute, ObservationTableToJson(stack.observations)},
                   {"loom.version", std::string(VersionWithCommit())}},
                  {.compression = ExrCompression::kNone});
}

Result<ObservationStack> ReadObservationStack(const std::filesystem::path& path) {
  const std::string file = path.string();
  Result<ExrImage> exr = ReadExr(path);
  if (!exr.ok()) return exr.status();
  const auto text = [&](const std::string& key) -> Result<std::string> {
    const auto it = exr->attributes.find(key);
    if (it == exr->attributes.end() || !std::holds_alternative<std::string>(it->second)) {
      return DataLossError(file, "not an observation stack: no string attribute " + key);
    }
    return std::get<std::string>(it->second);
  };
  Result<std::string> table = text(kTableAttribute);
  if (!table.ok()) return table.status();
  Result<std::vector<StackObservation>> observations = ParseObservationTable(*table, file);
  if (!observations.ok()) return observations.status();
  ObservationStack stack;
  stack.image = std::move(exr->image);
  stack.observations = std::move(*observations);
  if (stack.image.channel_names() != StackChannelNames(stack.observations.size())) {
    return DataLossError(file, "its channels (" + std::to_string(stack.image.num_channels()) +
                                   ") are not pos.XYZ, normal.XYZ and obs0000.. for the " +
                                   std::to_string(stack.observations.size()) + " observations of its table");
  }
  const auto pixel_mm = exr->attributes.find("loom.pixel_mm");
  if (pixel_mm == exr->attributes.end() || !std::holds_alternative<double>(pixel_mm->second) ||
      !(std::get<double>(pixel_mm->second) >= kMinStackPixelMm && std::get<double>(pixel_mm->second) <= kMaxStackPixelMm)) {
    return DataLossError(file, "loom.pixel_mm is missing or not a pixel size in [" + std::to_string(kMinStackPixelMm) + ", " +
                                   std::to_string(kMaxStackPixelMm) + "] mm");
  }
  stack.pixel_mm = std::get<double>(pixel_mm->second);
  if (Result<std::string> rig = text("loom.rig"); rig.ok()) stack.rig = *rig;
  if (Result<std::string> source = text("loom.source"); source.ok()) stack.source = *source;
  for (int c = 0; c < stack.image.num_channels(); ++c) {
    LOOM_RETURN_IF_ERROR(CheckFinite(stack.image, c, c >= kStackGeometryChannels, file));
  }
  LOOM_RETURN_IF_ERROR(CheckUnitNormals(stack, file));
  return stack;
}

}  // namespace loom
