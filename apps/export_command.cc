// loom export: fitted SVBRDF maps (svbrdf.exr from loom fit) in a format renderers load.
// Today: glTF 2.0 with KHR_materials_anisotropy and KHR_materials_specular (fitting/gltf_export.h
// states the approximation). The AxF-style HDF5 export is not built yet (issue #7).
#include <iostream>
#include <variant>

#include "apps/command.h"
#include "core/exr_io.h"
#include "fitting/gltf_export.h"
#include "fitting/model/svbrdf_maps.h"

namespace loom::apps {
namespace {

Result<double> PixelMm(const ExrImage& maps, const std::string& path, double override_mm) {
  if (override_mm > 0) return override_mm;
  const auto it = maps.attributes.find("loom.pixel_mm");
  if (it != maps.attributes.end()) {
    if (const double* mm = std::get_if<double>(&it->second)) return *mm;
  }
  return InvalidArgumentError(path, "has no loom.pixel_mm attribute: give the maps' pixel size with --pixel-mm");
}

Status Export(const std::string& maps_path, double pixel_mm_option, const std::string& out) {
  LOOM_ASSIGN_OR_RETURN(const ExrImage maps, ReadExr(maps_path));
  if (!fitting::HasSvbrdfLayout(maps.image)) {
    return InvalidArgumentError(maps_path, "not SVBRDF maps: the first channels must be n_s.X ... F0");
  }
  LOOM_ASSIGN_OR_RETURN(const double pixel_mm, PixelMm(maps, maps_path, pixel_mm_option));
  LOOM_RETURN_IF_ERROR(fitting::WriteGltf(maps.image, pixel_mm, out));
  std::cout << "wrote " << out << "/material.gltf: a " << maps.image.width() * pixel_mm << " × "
            << maps.image.height() * pixel_mm << " mm quad with base colour, specular colour, roughness, normal and "
            << "anisotropy textures (GD10-Ward approximated by glTF's anisotropic GGX)\n";
  return Status::Ok();
}

}  // namespace

int RunExport(int argc, char** argv) {
  CLI::App app("Export fitted SVBRDF maps for renderers: glTF 2.0 with KHR_materials_anisotropy and "
               "KHR_materials_specular",
               "loom export");
  AddCommonOptions(app);
  std::string maps, out;
  double pixel_mm = 0;
  app.add_option("maps", maps, "Fitted maps (svbrdf.exr from loom fit)")->required();
  app.add_option("--gltf", out, "Directory to write: material.gltf, material.bin and its PNG textures")->required();
  app.add_option("--pixel-mm", pixel_mm, "The maps' pixel size (default: their loom.pixel_mm attribute)")
      ->check(CLI::PositiveNumber);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  const Status done = Export(maps, pixel_mm, out);
  return done.ok() ? kExitOk : ReportFailure(done);
}

}  // namespace loom::apps
