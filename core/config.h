#pragma once
// YAML configuration with strict keys. Every loom config file (rig, plan, training, ...)
// starts with `schema_version: N`. Readers pull each key they know; whatever is left over is an
// unknown key and an error, so a typo never passes silently. All problems of a file are
// collected and reported together, each naming the file, the key path and the line:
//
//   invalid argument: configs/rig/tac7.yaml: 2 problems:
//     key 'cameras[1].exposur_us' (line 31): unknown key (did you mean 'exposure_us'?)
//     key 'turntable.speed_deg_s' (line 52): expected a number, got 'fast'
//
// Usage:
//   LOOM_ASSIGN_OR_RETURN(ConfigDocument doc, ConfigDocument::LoadFile(path, kRigSchemaVersion));
//   ConfigNode root = doc.root();
//   root.Required("name", &options.name);
//   for (ConfigNode cam : root.Sequence("cameras")) cam.Optional("gain", &camera.gain);
//   LOOM_RETURN_IF_ERROR(doc.Finish());
//
// yaml-cpp stays behind this interface. Not thread-safe: one reader per document.

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "core/status.h"

namespace loom {

namespace internal {
struct ConfigState;
}

class ConfigNode {
 public:
  // Scalars and lists. `Required` records an error if the key is absent; `Optional` leaves
  // `*out` (its default) untouched. A value of the wrong type is an error either way.
#define LOOM_CONFIG_ACCESSORS(Type)                     \
  void Required(std::string_view key, Type* out) const; \
  void Optional(std::string_view key, Type* out) const;
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
  LOOM_CONFIG_ACCESSORS(Eigen::Matrix3d)  // three rows of three
#undef LOOM_CONFIG_ACCESSORS

  bool Has(std::string_view key) const;
  // Marks `key` as read without reading it: for a command that uses part of a file whose other
  // sections belong to other readers (a missing key is fine).
  void Ignore(std::string_view key) const;
  // Keys of this mapping in file order (for maps keyed by name). Marks none as read.
  std::vector<std::string> Keys() const;

  // A nested mapping. A missing or non-map value is recorded as an error and an empty node is
  // returned, so reading can go on and report every problem at once.
  ConfigNode Child(std::string_view key) const;
  std::optional<ConfigNode> OptionalChild(std::string_view key) const;
  // A sequence of mappings ("cameras: [{...}, {...}]").
  std::vector<ConfigNode> Sequence(std::string_view key) const;
  std::vector<ConfigNode> OptionalSequence(std::string_view key) const;

  // Records a semantic problem with a key of this node (e.g. a value out of range).
  void AddError(std::string_view key, std::string_view message) const;

  // Dotted path of this node in the document, e.g. "cameras[2]"; empty for the root.
  const std::string& path() const;

 private:
  friend class ConfigDocument;
  ConfigNode(std::shared_ptr<internal::ConfigState> state, size_t index) : state_(std::move(state)), index_(index) {}

  std::shared_ptr<internal::ConfigState> state_;
  size_t index_ = 0;  // into state_->nodes
};

class ConfigDocument {
 public:
  // Parses the file and checks `schema_version` (required, 1 ≤ v ≤ supported_schema_version).
  static Result<ConfigDocument> LoadFile(const std::filesystem::path& path, int supported_schema_version);
  // Same for text; `source_name` stands in for the file name in messages.
  static Result<ConfigDocument> LoadString(std::string_view text, std::string source_name, int supported_schema_version);

  int schema_version() const { return schema_version_; }
  const std::string& source_name() const;
  ConfigNode root() const;

  // Every problem recorded while reading, plus every key nobody read, as one status naming
  // the file; OK if there were none. Call once all readers are done.
  Status Finish() const;

 private:
  ConfigDocument() = default;
  std::shared_ptr<internal::ConfigState> state_;
  int schema_version_ = 0;
};

}  // namespace loom
