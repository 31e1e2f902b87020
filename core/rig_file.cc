#include "core/rig_file.h"

#include <algorithm>
#include <array>

#include "core/check.h"

namespace loom {
namespace {

// The mappings other modules read; `seed` is a scalar that Seed() reads.
constexpr std::array<std::string_view, 7> kSections = {"geometry",      "devices",     "sample",       "as_built",
                                                       "recalibration", "light_drift", "device_faults"};

void CheckIsSection(std::string_view key) {
  LOOM_CHECK(std::find(kSections.begin(), kSections.end(), key) != kSections.end()) << "no rig file section '" << key << "'";
}

}  // namespace

RigFile::RigFile(ConfigDocument doc) : doc_(std::move(doc)) { doc_.root().Required("name", &name_); }

Result<RigFile> RigFile::Load(const std::filesystem::path& path) {
  LOOM_ASSIGN_OR_RETURN(ConfigDocument doc, ConfigDocument::LoadFile(path, kRigSchemaVersion));
  return RigFile(std::move(doc));
}

Result<RigFile> RigFile::Parse(std::string_view text, std::string source) {
  LOOM_ASSIGN_OR_RETURN(ConfigDocument doc, ConfigDocument::LoadString(text, std::move(source), kRigSchemaVersion));
  return RigFile(std::move(doc));
}

bool RigFile::Has(std::string_view section) const {
  CheckIsSection(section);
  return doc_.root().Has(section);
}

std::optional<ConfigNode> RigFile::Section(std::string_view key) const {
  CheckIsSection(key);
  return doc_.root().OptionalChild(key);
}

Result<RigModel> RigFile::Model() const {
  const std::optional<ConfigNode> geometry = Section("geometry");
  if (!geometry) {
    return InvalidArgumentError(
        source(), "has no 'geometry:' section: planning, calibration and reconstruction need the rig's description");
  }
  RigModel model = ReadRigModel(*geometry);
  model.name = name_;
  return model;
}

int RigFile::Seed() const {
  int seed = 0;
  doc_.root().Optional("seed", &seed);
  return seed;
}

Status RigFile::Finish() const {
  for (std::string_view section : kSections) doc_.root().Ignore(section);
  doc_.root().Ignore("seed");
  return doc_.Finish();
}

Result<RigModel> LoadRigModel(const std::filesystem::path& path) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Load(path));
  LOOM_ASSIGN_OR_RETURN(RigModel model, file.Model());
  LOOM_RETURN_IF_ERROR(file.Finish());
  return model;
}

Result<RigModel> RigModelFromText(std::string_view text, std::string source) {
  LOOM_ASSIGN_OR_RETURN(const RigFile file, RigFile::Parse(text, std::move(source)));
  LOOM_ASSIGN_OR_RETURN(RigModel model, file.Model());
  LOOM_RETURN_IF_ERROR(file.Finish());
  return model;
}

}  // namespace loom
