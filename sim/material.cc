#include "sim/material.h"

#include "core/version.h"
#include "fitting/model/svbrdf_maps.h"
#include "sim/reflectance.h"

namespace loom::sim {

Status WriteMaterial(const Material& material, const std::filesystem::path& path) {
  ExrAttributes attributes = material.provenance;
  attributes["loom.material"] = material.name;
  attributes["loom.pixel_mm"] = material.pixel_mm;
  attributes["loom.units"] = std::string("albedos linear sRGB; sigma unitless; alpha rad; height mm");
  attributes["loom.version"] = std::string(VersionWithCommit());
  return WriteExr(path, material.maps, attributes);
}

Result<Material> ReadMaterial(const std::filesystem::path& path) {
  LOOM_ASSIGN_OR_RETURN(ExrImage exr, ReadExr(path));
  if (!fitting::HasSvbrdfLayout(exr.image)) {
    return InvalidArgumentError(path.string(), "not an SVBRDF map file: the first channels must be n_s.X ... F0");
  }
  if (Result<std::optional<BeyondLayout>> beyond = FindBeyondChannels(exr.image); !beyond.ok()) {
    return beyond.status().WithContext(path.string());
  }
  Material material;
  material.maps = std::move(exr.image);
  const auto pixel = exr.attributes.find("loom.pixel_mm");
  if (pixel == exr.attributes.end() || !std::holds_alternative<double>(pixel->second)) {
    return InvalidArgumentError(path.string(), "attribute 'loom.pixel_mm' (double) is missing");
  }
  material.pixel_mm = std::get<double>(pixel->second);
  if (const auto name = exr.attributes.find("loom.material");
      name != exr.attributes.end() && std::holds_alternative<std::string>(name->second)) {
    material.name = std::get<std::string>(name->second);
  }
  material.provenance = std::move(exr.attributes);
  return material;
}

}  // namespace loom::sim
