// loom sim capture: photographs of a curved object or a flat material as other rigs take them
// (photos/simulated_capture.h writes their layouts), with their truth. Apart from the rest of
// `loom sim` because photos/ is the full build's alone: the GPU build has no image codecs.
#include <iostream>
#include <memory>

#include "apps/command.h"
#include "core/exr_io.h"
#include "photos/simulated_capture.h"

namespace loom::apps {
namespace {

struct CaptureArguments {
  photos::SimulatedCaptureRequest request;
  std::string layout = "ps", shape = "sphere", truth, normals, out, flash_offset;
  bool force = false;
};

Status ParseCaptureLayout(CaptureArguments& args) {
  LOOM_ASSIGN_OR_RETURN(args.request.layout, photos::ParseLayout(args.layout, "--layout"));
  if (args.shape != "sphere" && args.shape != "cylinder") {
    return InvalidArgumentError("--shape " + args.shape, "expected sphere or cylinder");
  }
  args.request.object.shape = args.shape == "sphere" ? sim::ObjectShape::kSphere : sim::ObjectShape::kCylinder;
  if (args.flash_offset.empty()) return Status::Ok();
  LOOM_ASSIGN_OR_RETURN(args.request.flash.flash_offset_cm, photos::ParseFlashOffset(args.flash_offset, "--flash-offset"));
  return Status::Ok();
}

// Photographs as another rig takes them (photos/simulated_capture.h), with the truth beside (not
// inside) the folder: loom import reads every image of a folder in some layouts.
Status Capture(CaptureArguments args) {
  LOOM_RETURN_IF_ERROR(CheckOutputFiles({{"--truth", args.truth}, {"--normals", args.normals}}, args.force));
  LOOM_RETURN_IF_ERROR(ParseCaptureLayout(args));
  // --size, --noise and --seed are the flash layout's too.
  args.request.sample.size_px = args.request.object.size_px;
  args.request.flash.noise = args.request.object.noise;
  args.request.flash.seed = args.request.object.seed;
  LOOM_ASSIGN_OR_RETURN(const photos::SimulatedCapture capture, photos::WriteSimulatedCapture(args.request, args.out));
  if (!args.truth.empty()) LOOM_RETURN_IF_ERROR(WriteExr(args.truth, capture.truth, {{"loom.kind", std::string("svbrdf maps")}}));
  if (!args.normals.empty() && capture.normals) LOOM_RETURN_IF_ERROR(WriteExr(args.normals, *capture.normals, {}));
  std::cout << "wrote " << args.out << ": " << capture.description << "; the truth's albedos in the stored units\n";
  return Status::Ok();
}

}  // namespace

std::function<Status()> AddSimCaptureCommand(CLI::App& sim) {
  auto capture = std::make_shared<CaptureArguments>();
  CLI::App* capture_app = sim.add_subcommand(
      "capture",
      "Photographs as other rigs take them, with their truth: a curved object under directional lights (ps, lp) or a "
      "flat material under a phone's flash (flash)");
  capture_app->add_option("--layout", capture->layout, "ps, lp (a light dome's: sRGB JPEGs) or flash")->capture_default_str();
  capture_app->add_option("--shape", capture->shape, "ps and lp: sphere or cylinder")->capture_default_str();
  capture_app->add_option("--object", capture->request.sample.kind, "flash: the material (fabric, fabric-out-of-model)")
      ->capture_default_str();
  capture_app->add_option("--object-seed", capture->request.sample.seed, "flash: the material's seed");
  capture_app->add_option("--images", capture->request.flash.images, "flash: photographs")->check(CLI::Range(2, 100));
  capture_app->add_option("--flash-offset", capture->flash_offset,
                          "flash: X,Y,Z cm of the flash from the lens (y up the image; default 0.8,0,0)");
  capture_app->add_option("--size", capture->request.object.size_px, "Image size in pixels (square)")->check(CLI::Range(4, 4096));
  capture_app->add_option("--pixel-mm", capture->request.sample.pixel_mm, "flash: the material's pixel size")
      ->check(CLI::PositiveNumber);
  capture_app->add_option("--lights", capture->request.object.lights, "Directional lights, spread over a cap")
      ->check(CLI::Range(3, 1000));
  capture_app->add_option("--max-light-deg", capture->request.object.max_light_deg, "The cap's half-angle")
      ->check(CLI::Range(1.0, 89.0));
  fitting::WardParams<double>& object_material = capture->request.object.material;
  capture_app
      ->add_option_function<double>(
          "--sigma", [&object_material](double sigma) { object_material.sigma_x = object_material.sigma_y = sigma; },
          "The material's lobe width")
      ->check(CLI::Range(0.01, 1.0));
  capture_app
      ->add_option_function<double>(
          "--specular", [&object_material](double a_s) { object_material.a_s.setConstant(a_s); },
          "The material's specular albedo (grey)")
      ->check(CLI::Range(0.0, 1.0));
  capture_app->add_option("--noise", capture->request.object.noise, "Relative sensor noise")->check(CLI::Range(0.0, 0.5));
  capture_app->add_flag_callback(
      "--out-of-model",
      [capture] {
        capture->request.object.beyond = {.coat = Eigen::Vector3d::Constant(0.1), .coat_roughness = 0.1, .meso_deg = 4};
      },
      "ps: the material shows what GD10 cannot: a grey GGX coat of albedo 0.1 and roughness 0.1, and 4° of mesostructure");
  capture_app
      ->add_option("--subpixels", capture->request.object.subpixels,
                   "ps and lp: each pixel the mean of N × N points of its footprint, as a camera integrates (edge "
                   "pixels mix normals and the background); the truth stays the pixel centre's")
      ->check(CLI::Range(1, 16));
  capture_app->add_option("--seed", capture->request.object.seed, "Seed of the noise");
  capture_app
      ->add_option("--light-error-deg", capture->request.light_error_deg,
                   "ps and lp: each light's direction in the files turned by |N(0, this)| degrees from the true one, as a "
                   "dome's calibration errs")
      ->check(CLI::Range(0.0, 20.0));
  capture_app
      ->add_option("--intensity-error", capture->request.intensity_error,
                   "ps and lp: each light's true intensity off the files' by a factor N(1, this)")
      ->check(CLI::Range(0.0, 0.5));
  capture_app->add_option("--truth", capture->truth, "Also write the true maps on the image's grid (OpenEXR)");
  capture_app->add_option("--normals", capture->normals, "Also write the true normals (OpenEXR X, Y, Z; y up)");
  capture_app->add_option("--out", capture->out, "Folder for the capture")->required();
  AddForceOption(*capture_app, capture->force);
  return [capture] { return Capture(*capture); };
}

}  // namespace loom::apps
