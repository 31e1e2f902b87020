#pragma once
// A rig YAML (configs/rig/*.yaml): the one reader of its top level. Each part of loom reads the
// section it owns; Finish() then reports every problem of the file together, a top-level key
// that is none of these included:
//   schema_version: 1
//   name:          the rig's name
//   geometry:      its description (core/rig_model.h): planning, calibration, reconstruction
//   devices:       backends and their settings (hal::Rig::Create)
//   sample:        what a simulated rig's turntable holds (sim::ReadSampleSpec)
//   seed:          a simulated rig's noise seed
//   as_built:      how simulated hardware differs from the geometry (hal/sim/as_built.h)
//   recalibration: `loom calibrate check`'s thresholds (calibration::ReadDriftThresholds)
//   light_drift:   drift references in material scans and their warning (scan::ReadLightDriftSettings)

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "core/config.h"
#include "core/rig_model.h"

namespace loom {

inline constexpr int kRigSchemaVersion = 1;

class RigFile {
 public:
  static Result<RigFile> Load(const std::filesystem::path& path);
  // The text of a rig file (a scan's snapshot); `source` names it in messages.
  static Result<RigFile> Parse(std::string_view text, std::string source);

  const std::string& name() const { return name_; }
  const std::string& source() const { return doc_.source_name(); }
  bool Has(std::string_view section) const;
  // One of the sections above, when the file has it, to be read once. Problems found while
  // reading it are kept for Finish().
  std::optional<ConfigNode> Section(std::string_view key) const;
  // `geometry:` as the rig's model, named after the rig; an error naming the file when it has none.
  Result<RigModel> Model() const;
  // The simulated rig's noise seed (0 when the file has none).
  int Seed() const;
  // Every problem recorded while the sections were read, and every unknown key; sections that
  // nobody read are fine.
  Status Finish() const;

 private:
  explicit RigFile(ConfigDocument doc);

  ConfigDocument doc_;
  std::string name_;
};

// Only the rig's description, for what plans, calibrates or reconstructs rather than drives.
Result<RigModel> LoadRigModel(const std::filesystem::path& path);
// The same from the text of a rig file (a scan's snapshot); `source` names it in messages.
Result<RigModel> RigModelFromText(std::string_view text, std::string source);

}  // namespace loom
