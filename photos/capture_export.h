#pragma once
// A capture written in a layout that `loom import` reads (capture_import.h): how `loom sim
// capture` hands a simulated object to the same import every real capture goes through.

#include <filesystem>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/status.h"

namespace loom::photos {

// The `ps` layout: NNN.png as 16-bit linear PNG (values scaled by 1/`white` and clipped at 1),
// filenames.txt, light_directions.txt (unit, x right, y up, z towards the camera),
// light_intensities.txt (1 1 1) and, when given, mask.png (255 = the object). `images`: linear
// radiance with channels R, G, B, one per light.
struct PhotometricStereoCapture {
  std::vector<Image> images;
  std::vector<Eigen::Vector3d> light_directions;  // y up
  std::optional<Image> mask;                      // one channel, non-zero = the object
  double white = 1;                               // the radiance stored as the top value
};
Status WritePhotometricStereo(const std::filesystem::path& dir, const PhotometricStereoCapture& capture);
// The same capture in the `lp` layout of light domes for reflectance transformation imaging:
// NNN.jpg as 8-bit sRGB JPEG (quality 95), capture.lp (the count, then "NNN.jpg x y z" a line)
// and, when given, mask.png.
Status WriteLightPositions(const std::filesystem::path& dir, const PhotometricStereoCapture& capture);

// The `flash` layout: NN.png as 8-bit PNG with gamma 2.2 (value^(1/2.2), clipped at 1),
// camera_pos.txt, light_pos.txt ("x,y,z" cm, y up the image), image_size.txt (cm) and
// light_power.txt. `images`: linear radiance as the importer's model has it (per unit of
// light_power / cm²), channels R, G, B.
struct FlashCapture {
  std::vector<Image> images;
  std::vector<Eigen::Vector3d> cameras_cm, lights_cm;  // y up
  double width_cm = 1;
  Eigen::Vector3d power = Eigen::Vector3d::Ones();
  double white = 1;  // the radiance stored as 255
};
Status WriteFlash(const std::filesystem::path& dir, const FlashCapture& capture);

}  // namespace loom::photos
