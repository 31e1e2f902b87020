// loom import: a folder of photographs from another rig (a photometric-stereo benchmark, a light
// dome, phone-flash captures) as an observation stack that loom fit and loom eval take
// (photos/capture_import.h says the layouts).
#include <iostream>

#include "apps/command.h"
#include "core/file_io.h"
#include "core/observation_stack.h"
#include "photos/capture_import.h"

namespace loom::apps {
namespace {

struct ImportArguments {
  std::string dir, out, layout, encoding, flash_offset, json, held_out;
  int hold_out = -1;
  photos::ImportOptions options;
  double scale = 0;  // 0: automatic
  bool force = false;
};

Status Import(ImportArguments args) {
  if (!args.layout.empty()) {
    LOOM_ASSIGN_OR_RETURN(args.options.layout, photos::ParseLayout(args.layout, "--layout"));
  }
  if (!args.encoding.empty()) {
    LOOM_ASSIGN_OR_RETURN(args.options.encoding, photos::ParseEncoding(args.encoding, "--encoding"));
  }
  if (!args.flash_offset.empty()) {
    LOOM_ASSIGN_OR_RETURN(args.options.flash_offset_cm, photos::ParseFlashOffset(args.flash_offset, "--flash-offset"));
  }
  if (args.scale > 0) args.options.scale = args.scale;
  if ((args.hold_out >= 0) != !args.held_out.empty()) {
    return InvalidArgumentError("--hold-out", "give both --hold-out K and --held-out FILE, or neither");
  }
  if (args.hold_out >= 0) args.options.hold_out = args.hold_out;
  LOOM_RETURN_IF_ERROR(CheckOutputFiles({{"--out", args.out}, {"--held-out", args.held_out}, {"--json", args.json}}, args.force));
  LOOM_ASSIGN_OR_RETURN(const photos::ImportResult imported, photos::ImportCapture(args.dir, args.options));
  imported.Report(std::cout);
  LOOM_RETURN_IF_ERROR(WriteObservationStack(args.out, imported.stack));
  if (imported.held_out) {
    LOOM_RETURN_IF_ERROR(WriteObservationStack(args.held_out, *imported.held_out));
    std::cout << "wrote " << args.held_out << ": image " << args.hold_out << " alone, left out of " << args.out << "\n";
  }
  LOOM_RETURN_IF_ERROR(WriteJsonReport(args.json, imported.ToJson()));
  std::cout << "wrote " << args.out << "\n";
  return Status::Ok();
}

}  // namespace

int RunImport(int argc, char** argv) {
  CLI::App app("Import photographs from another rig as an observation stack (layouts: ps, lp, flash)", "loom import");
  AddCommonOptions(app);
  ImportArguments args;
  app.add_option("dir", args.dir, "Folder of photographs and their lighting")->required();
  app.add_option("--out", args.out, "Observation stack to write (OpenEXR)")->required();
  app.add_option("--layout", args.layout,
                 "ps (filenames.txt, light_directions.txt, light_intensities.txt, mask.png), lp (a .lp file) or flash "
                 "(camera_pos.txt, light_pos.txt, image_size.txt, light_power.txt or capture.json); default: detected");
  app.add_option("--encoding", args.encoding,
                 "linear, srgb or gamma:G (default: 16-bit PNG and EXR linear, 8-bit sRGB; the flash layout gamma:2.2)");
  app.add_option("--downsample", args.options.downsample, "N x N image pixels per stack pixel (block means of seen values)")
      ->check(CLI::Range(1, 64));
  app.add_option("--scale", args.scale, "Radiance scale (default: automatic, so that albedos stay within the model's bound)")
      ->check(CLI::PositiveNumber);
  app.add_option("--pixel-mm", args.options.pixel_mm, "ps and lp: an image pixel's size on the object in mm")
      ->capture_default_str()
      ->check(CLI::Range(kMinStackPixelMm, kMaxStackPixelMm));
  app.add_option("--flash-offset", args.flash_offset,
                 "flash: X,Y,Z in cm (sample frame, y up the image) added to every light position: where the flash "
                 "sits beside the lens");
  app.add_option("--json", args.json, "Also write what was imported as JSON");
  app.add_option("--hold-out", args.hold_out,
                 "Leave image K (0-based, in the layout's order) out of --out and write it alone to --held-out: fit "
                 "--out, then loom eval the fit with --stack HELD to score it on a view it never saw")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--held-out", args.held_out, "With --hold-out: the stack of the held-out image");
  AddForceOption(app, args.force);
  if (std::optional<int> exit = ParseCommandLine(app, argc, argv)) return *exit;
  return ExitCode(Import(std::move(args)));
}

}  // namespace loom::apps
