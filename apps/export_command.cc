// loom export: fitted SVBRDF maps (svbrdf.exr from loom fit) in the formats renderers and
// material tools load: glTF 2.0 with KHR_materials_anisotropy and KHR_materials_specular
// (fitting/report/gltf_export.h states the approximation), MaterialX standard_surface
// (fitting/report/mtlx_export.h) and X-Rite's AxF container's SVBRDF
// (fitting/io/axf_export.h: the same model, no approximation).
#include <iostream>
#include <map>

#include "apps/command.h"
#include "fitting/report/export_maps.h"
#include "fitting/report/gltf_export.h"

namespace loom::apps {

int RunExport(int argc, char** argv) {
  CLI::App app(
      "Export fitted SVBRDF maps: glTF 2.0 with KHR_materials_anisotropy and KHR_materials_specular "
      "for renderers, a MaterialX document for studio pipelines, and/or an AxF file (X-Rite's HDF5 container) with "
      "the model's own parameters",
      "loom export");
  AddCommonOptions(app);
  fitting::ExportRequest args;
  app.add_option("maps", args.maps, "Fitted maps (svbrdf.exr from loom fit, or an AxF file's SVBRDF)")->required();
  app.add_option("--gltf", args.gltf, "Directory to write: material.gltf, material.bin and its PNG textures");
  app.add_option("--gltf-anisotropy", args.anisotropy,
                 "auto: KHR_materials_anisotropy unless the shading normals tilt more than the lobes are wide; on; off")
      ->transform(
          CLI::CheckedTransformer(std::map<std::string, fitting::GltfAnisotropy>{{"auto", fitting::GltfAnisotropy::kAuto},
                                                                                 {"on", fitting::GltfAnisotropy::kOn},
                                                                                 {"off", fitting::GltfAnisotropy::kOff}}));
  app.add_option("--axf", args.axf, "AxF file to write: the SVBRDF in the model's own parameters (docs/formats.md)");
  app.add_option("--mtlx", args.mtlx, "Directory to write: material.mtlx (a MaterialX standard_surface) and its PNG textures");
  app.add_option("--pixel-mm", args.pixel_mm, "The maps' pixel size (default: their loom.pixel_mm attribute)")
      ->check(CLI::PositiveNumber);
  AddForceOption(app, args.force);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  if (args.gltf.empty() && args.axf.empty() && args.mtlx.empty()) {  // a usage error, as CLI11's own are
    ExitCode(InvalidArgumentError("loom export", "nothing to write: give --gltf DIR, --axf FILE and/or --mtlx DIR"));
    return kExitUsage;
  }
  return ExitCode(fitting::ExportMaps(args, std::cout));
}

}  // namespace loom::apps
