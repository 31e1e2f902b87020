#include "core/config.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "core/check.h"

namespace loom {
namespace internal {

struct ConfigNodeRecord {
  YAML::Node node;
  std::string path;
  bool is_map = false;
  std::set<std::string, std::less<>> read_keys;   // keys consumed by a reader
  std::set<std::string, std::less<>> known_keys;  // keys asked for, present or not (suggestions)
};

struct ConfigState {
  std::string source;
  std::vector<ConfigNodeRecord> nodes;
  std::vector<std::string> errors;
};

}  // namespace internal

namespace {

using internal::ConfigNodeRecord;
using internal::ConfigState;

std::string JoinPath(std::string_view path, std::string_view key) {
  if (path.empty()) return std::string(key);
  return std::string(path) + "." + std::string(key);
}

std::string DescribeKind(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) return "nothing";
  if (node.IsMap()) return "a mapping";
  if (node.IsSequence()) return "a list";
  return "'" + node.Scalar() + "'";
}

int LineOf(const YAML::Node& node) { return node.Mark().line + 1; }

size_t EditDistance(std::string_view a, std::string_view b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// Decoders return an error text, or nothing on success.
using DecodeError = std::optional<std::string>;

template <typename T>
DecodeError DecodeScalar(const YAML::Node& node, std::string_view type_name, T* out) {
  if (!node.IsScalar()) return "expected " + std::string(type_name) + ", got " + DescribeKind(node);
  try {
    *out = node.as<T>();
  } catch (const YAML::BadConversion&) {
    return "expected " + std::string(type_name) + ", got " + DescribeKind(node);
  }
  return std::nullopt;
}

DecodeError Decode(const YAML::Node& n, bool* out) { return DecodeScalar(n, "true or false", out); }
DecodeError Decode(const YAML::Node& n, int* out) { return DecodeScalar(n, "an integer", out); }
// No loom setting means anything when infinite or NaN, and a NaN slips through every range check
// written as `x <= 0`: such values are refused where they are read.
template <typename T>
DecodeError DecodeFinite(const YAML::Node& node, T* out) {
  T value = 0;
  if (DecodeError error = DecodeScalar(node, "a number", &value)) return error;
  if (!std::isfinite(value)) return "expected a finite number, got '" + node.Scalar() + "'";
  *out = value;
  return std::nullopt;
}

DecodeError Decode(const YAML::Node& n, double* out) { return DecodeFinite(n, out); }
DecodeError Decode(const YAML::Node& n, float* out) { return DecodeFinite(n, out); }
DecodeError Decode(const YAML::Node& n, std::string* out) { return DecodeScalar(n, "a string", out); }

template <typename T>
DecodeError DecodeList(const YAML::Node& node, std::vector<T>* out) {
  if (!node.IsSequence()) return "expected a list, got " + DescribeKind(node);
  std::vector<T> values(node.size());
  for (size_t i = 0; i < node.size(); ++i) {
    if (DecodeError error = Decode(node[i], &values[i])) {
      return "element " + std::to_string(i) + ": " + *error;
    }
  }
  *out = std::move(values);
  return std::nullopt;
}

DecodeError Decode(const YAML::Node& n, std::vector<int>* out) { return DecodeList(n, out); }
DecodeError Decode(const YAML::Node& n, std::vector<double>* out) { return DecodeList(n, out); }
DecodeError Decode(const YAML::Node& n, std::vector<std::string>* out) { return DecodeList(n, out); }

template <int N>
DecodeError DecodeFixed(const YAML::Node& node, Eigen::Matrix<double, N, 1>* out) {
  std::vector<double> values;
  if (DecodeError error = DecodeList(node, &values)) return error;
  if (values.size() != N) {
    return "expected a list of " + std::to_string(N) + " numbers, got " + std::to_string(values.size());
  }
  *out = Eigen::Map<const Eigen::Matrix<double, N, 1>>(values.data());
  return std::nullopt;
}

DecodeError Decode(const YAML::Node& n, Eigen::Vector2d* out) { return DecodeFixed<2>(n, out); }
DecodeError Decode(const YAML::Node& n, Eigen::Vector3d* out) { return DecodeFixed<3>(n, out); }

DecodeError Decode(const YAML::Node& node, Eigen::Matrix3d* out) {
  if (!node.IsSequence() || node.size() != 3) {
    return "expected three rows of three numbers, got " + DescribeKind(node);
  }
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    Eigen::Vector3d row;
    if (DecodeError error = DecodeFixed<3>(node[r], &row)) {
      return "row " + std::to_string(r) + ": " + *error;
    }
    m.row(r) = row.transpose();
  }
  *out = m;
  return std::nullopt;
}

std::string KeyMessage(const std::string& key_path, int line, std::string_view message) {
  return "key '" + key_path + "' (line " + std::to_string(line) + "): " + std::string(message);
}

size_t AddRecord(ConfigState& state, YAML::Node node, std::string path) {
  ConfigNodeRecord record;
  record.is_map = node.IsMap();
  if (record.is_map) {
    for (const auto& entry : node) {
      // `? [a, b]: x` is valid YAML, but no loom key is a list or a map.
      if (!entry.first.IsScalar()) {
        const std::string problem = "a key must be a plain name, not " + DescribeKind(entry.first);
        state.errors.push_back(path.empty() ? "line " + std::to_string(LineOf(entry.first)) + ": " + problem
                                            : KeyMessage(path, LineOf(entry.first), problem));
      }
    }
  }
  record.node = std::move(node);
  record.path = std::move(path);
  state.nodes.push_back(std::move(record));
  return state.nodes.size() - 1;
}

// A const lookup: yaml-cpp's non-const operator[] would insert the key.
YAML::Node Find(const YAML::Node& map, std::string_view key) { return map[std::string(key)]; }

// Looks `key` up in the record's mapping, marking it known (and read if present).
YAML::Node Lookup(ConfigNodeRecord& record, std::string_view key) {
  record.known_keys.emplace(key);
  if (!record.is_map) return YAML::Node(YAML::NodeType::Undefined);
  YAML::Node value = Find(record.node, key);
  if (value.IsDefined()) record.read_keys.emplace(key);
  return value;
}

template <typename T>
void ReadValue(ConfigState& state, size_t index, std::string_view key, T* out, bool required) {
  ConfigNodeRecord& record = state.nodes[index];
  const YAML::Node value = Lookup(record, key);
  const std::string key_path = JoinPath(record.path, key);
  if (!value.IsDefined()) {
    if (required) {
      state.errors.push_back(KeyMessage(key_path, LineOf(record.node), "missing required key"));
    }
    return;
  }
  if (DecodeError error = Decode(value, out)) {
    state.errors.push_back(KeyMessage(key_path, LineOf(value), *error));
  }
}

std::string Suggestion(const ConfigNodeRecord& record, std::string_view unknown) {
  std::string best;
  size_t best_distance = std::max<size_t>(2, unknown.size() / 3) + 1;
  for (const std::string& known : record.known_keys) {
    const size_t distance = EditDistance(unknown, known);
    if (distance < best_distance) {
      best_distance = distance;
      best = known;
    }
  }
  return best.empty() ? "" : " (did you mean '" + best + "'?)";
}

}  // namespace

#define LOOM_CONFIG_ACCESSORS(Type)                                                                                             \
  void ConfigNode::Required(std::string_view key, Type* out) const { ReadValue(*state_, index_, key, out, /*required=*/true); } \
  void ConfigNode::Optional(std::string_view key, Type* out) const { ReadValue(*state_, index_, key, out, /*required=*/false); }
LOOM_CONFIG_ACCESSORS(bool)
LOOM_CONFIG_ACCESSORS(int)
LOOM_CONFIG_ACCESSORS(double)
LOOM_CONFIG_ACCESSORS(float)
LOOM_CONFIG_ACCESSORS(std::string)
LOOM_CONFIG_ACCESSORS(std::vector<int>)
LOOM_CONFIG_ACCESSORS(std::vector<double>)
LOOM_CONFIG_ACCESSORS(std::vector<std::string>)
LOOM_CONFIG_ACCESSORS(Eigen::Vector2d)
LOOM_CONFIG_ACCESSORS(Eigen::Vector3d)
LOOM_CONFIG_ACCESSORS(Eigen::Matrix3d)
#undef LOOM_CONFIG_ACCESSORS

bool ConfigNode::Has(std::string_view key) const {
  const ConfigNodeRecord& record = state_->nodes[index_];
  return record.is_map && Find(record.node, key).IsDefined();
}

void ConfigNode::Ignore(std::string_view key) const { Lookup(state_->nodes[index_], key); }

std::vector<std::string> ConfigNode::Keys() const {
  const ConfigNodeRecord& record = state_->nodes[index_];
  std::vector<std::string> keys;
  if (!record.is_map) return keys;
  for (const auto& entry : record.node) {
    if (entry.first.IsScalar()) keys.push_back(entry.first.as<std::string>());
  }
  return keys;
}

ConfigNode ConfigNode::Child(std::string_view key) const {
  std::optional<ConfigNode> child = OptionalChild(key);
  if (child) return *child;
  AddError(key, "missing required key");
  return ConfigNode(state_, AddRecord(*state_, YAML::Node(), JoinPath(path(), key)));
}

std::optional<ConfigNode> ConfigNode::OptionalChild(std::string_view key) const {
  ConfigNodeRecord& record = state_->nodes[index_];
  const YAML::Node value = Lookup(record, key);
  if (!value.IsDefined()) return std::nullopt;
  const std::string key_path = JoinPath(record.path, key);
  if (!value.IsMap()) {
    state_->errors.push_back(KeyMessage(key_path, LineOf(value), "expected a mapping, got " + DescribeKind(value)));
  }
  return ConfigNode(state_, AddRecord(*state_, value, key_path));
}

std::vector<ConfigNode> ConfigNode::Sequence(std::string_view key) const {
  if (!Has(key)) {
    state_->nodes[index_].known_keys.emplace(key);
    AddError(key, "missing required key");
    return {};
  }
  return OptionalSequence(key);
}

std::vector<ConfigNode> ConfigNode::OptionalSequence(std::string_view key) const {
  ConfigNodeRecord& record = state_->nodes[index_];
  const YAML::Node value = Lookup(record, key);
  if (!value.IsDefined()) return {};
  const std::string key_path = JoinPath(record.path, key);
  if (!value.IsSequence()) {
    state_->errors.push_back(KeyMessage(key_path, LineOf(value), "expected a list, got " + DescribeKind(value)));
    return {};
  }
  std::vector<ConfigNode> items;
  for (size_t i = 0; i < value.size(); ++i) {
    const std::string item_path = key_path + "[" + std::to_string(i) + "]";
    const YAML::Node item = value[i];
    if (!item.IsMap()) {
      state_->errors.push_back(KeyMessage(item_path, LineOf(item), "expected a mapping, got " + DescribeKind(item)));
    }
    items.push_back(ConfigNode(state_, AddRecord(*state_, item, item_path)));
  }
  return items;
}

void ConfigNode::AddError(std::string_view key, std::string_view message) const {
  const ConfigNodeRecord& record = state_->nodes[index_];
  const YAML::Node value = record.is_map ? Find(record.node, key) : YAML::Node();
  const int line = value.IsDefined() ? LineOf(value) : LineOf(record.node);
  state_->errors.push_back(KeyMessage(JoinPath(record.path, key), line, message));
}

const std::string& ConfigNode::path() const { return state_->nodes[index_].path; }

Result<ConfigDocument> ConfigDocument::LoadFile(const std::filesystem::path& path, int supported_schema_version) {
  // A config is a small text file: not a device (--rig /dev/zero reads without end) and not a
  // data file given by mistake.
  constexpr std::uintmax_t kMaxConfigBytes = 16 << 20;
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec)) {
    return InvalidArgumentError(path.string(), "not a regular file");
  }
  if (const std::uintmax_t bytes = std::filesystem::file_size(path, ec); !ec && bytes > kMaxConfigBytes) {
    return InvalidArgumentError(path.string(), std::to_string(bytes) + " bytes: too large for a config file (at most 16 MiB)");
  }
  std::ifstream in(path);
  if (!in) {
    if (!std::filesystem::exists(path, ec)) return NotFoundError(path.string(), "no such file");
    return IoError(path.string(), "cannot open for reading");
  }
  std::stringstream text;
  text << in.rdbuf();
  return LoadString(text.str(), path.string(), supported_schema_version);
}

namespace {

// YAML forbids a key twice in one mapping, but yaml-cpp keeps both and reads the first: a rig file
// edited by appending a corrected value would silently keep the old one.
Status CheckNoDuplicateKeys(const YAML::Node& node, const std::string& source_name) {
  if (node.IsSequence()) {
    for (const YAML::Node& item : node) LOOM_RETURN_IF_ERROR(CheckNoDuplicateKeys(item, source_name));
  }
  if (!node.IsMap()) return Status::Ok();
  std::set<std::string> keys;
  for (const auto& pair : node) {
    if (pair.first.IsScalar() && !keys.insert(pair.first.Scalar()).second) {
      return InvalidArgumentError(source_name, "line " + std::to_string(pair.first.Mark().line + 1) + ": key '" +
                                                   pair.first.Scalar() + "' appears twice in one mapping");
    }
    LOOM_RETURN_IF_ERROR(CheckNoDuplicateKeys(pair.second, source_name));
  }
  return Status::Ok();
}

}  // namespace

Result<ConfigDocument> ConfigDocument::LoadString(std::string_view text, std::string source_name, int supported_schema_version) {
  YAML::Node root;
  try {
    root = YAML::Load(std::string(text));
  } catch (const YAML::ParserException& e) {
    return InvalidArgumentError(source_name, "line " + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg);
  }
  if (!root.IsMap()) {
    return InvalidArgumentError(source_name,
                                "expected a mapping with 'schema_version' at the "
                                "top, got " +
                                    DescribeKind(root));
  }
  LOOM_RETURN_IF_ERROR(CheckNoDuplicateKeys(root, source_name));
  ConfigDocument doc;
  doc.state_ = std::make_shared<ConfigState>();
  doc.state_->source = source_name;
  AddRecord(*doc.state_, root, "");
  int version = 0;
  doc.root().Required("schema_version", &version);
  if (!doc.state_->errors.empty()) {
    return InvalidArgumentError(source_name, doc.state_->errors.front());
  }
  if (version < 1 || version > supported_schema_version) {
    return InvalidArgumentError(source_name, "key 'schema_version': version " + std::to_string(version) +
                                                 " is not supported (this loom reads 1.." +
                                                 std::to_string(supported_schema_version) + ")");
  }
  doc.schema_version_ = version;
  return doc;
}

const std::string& ConfigDocument::source_name() const { return state_->source; }

ConfigNode ConfigDocument::root() const { return ConfigNode(state_, 0); }

Status ConfigDocument::Finish() const {
  std::vector<std::string> problems = state_->errors;
  for (const ConfigNodeRecord& record : state_->nodes) {
    if (!record.is_map) continue;
    for (const auto& entry : record.node) {
      if (!entry.first.IsScalar()) continue;  // AddRecord reported it
      const std::string key = entry.first.as<std::string>();
      if (record.read_keys.contains(key)) continue;
      problems.push_back(KeyMessage(JoinPath(record.path, key), LineOf(entry.first), "unknown key" + Suggestion(record, key)));
    }
  }
  if (problems.empty()) return Status::Ok();
  if (problems.size() == 1) return InvalidArgumentError(state_->source, problems.front());
  std::string message = std::to_string(problems.size()) + " problems:";
  for (const std::string& problem : problems) message += "\n  " + problem;
  return InvalidArgumentError(state_->source, message);
}

}  // namespace loom
