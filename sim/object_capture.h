#pragma once
// Curved objects photographed as other rigs photograph them, for `loom sim capture`: a sphere or
// a cylinder of one GD10 material (its diffuse albedo varying across the object) under
// directional lights, seen by an orthographic camera from +z — the layout of photometric-stereo
// benchmarks — with the ground truth that imports of real captures lack: the normals, the mask
// and the maps on the grid `loom import` makes of the images.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/image.h"
#include "core/status.h"
#include "fitting/model/ward_gd10.h"
#include "sim/reflectance.h"

namespace loom::sim {

enum class ObjectShape { kSphere, kCylinder };

struct ObjectCaptureOptions {
  ObjectShape shape = ObjectShape::kSphere;
  int size_px = 64;  // the image is size × size; the object spans 90 % of it
  int lights = 48;   // on a spiral over the cap within max_light_deg of the view axis
  double max_light_deg = 60;
  // The material; its a_d is modulated across the object (×0.6–1.0 in stripes) so that the
  // albedo map has something to recover. n_s is ignored: the object's own normal.
  fitting::WardParams<double> material = {{0, 0, 1}, {0.55, 0.35, 0.2}, {0.25, 0.25, 0.25}, 0.15, 0.15, 0, 1};
  double noise = 0;  // relative Gaussian noise on every value (sensor), 0: none
  // Each pixel the mean over subpixels × subpixels points of its footprint, 0 where the object does
  // not cover a point, as a camera's pixel integrates: an edge pixel mixes normals and the
  // background. The mask, normals and truth stay those at the pixel's centre, as a benchmark's
  // ground truth is. 1: the centre alone.
  int subpixels = 1;
  uint64_t seed = 1;
  // What the material shows beyond GD10 (reflectance.h: a coat lobe, fibre masking,
  // mesostructure); none: GD10 exactly.
  BeyondGd10 beyond;
  Status Check() const;  // every problem, naming the field
};

struct ObjectCapture {
  std::vector<Image> images;                      // linear radiance, channels R, G, B, one per light
  std::vector<Eigen::Vector3d> light_directions;  // unit, x right, y up, z towards the camera
  Image mask;                                     // channel "mask": 1 on the object, 0 off it
  Image normals;                                  // channels X, Y, Z: x right, y up, z towards the camera; 0 off it
  Image truth;                                    // SVBRDF maps on the image's grid (stack frame: y down); NaN off it
};

// Irradiance 1 from every light; radiance = (a_d/π + a_s F D)(n·l) as the fitters model it, and
// what options.beyond adds to it.
ObjectCapture RenderObjectCapture(const ObjectCaptureOptions& options);

// A planar material photographed with a phone's flash, the layout of flash captures (MaterialGAN's):
// cameras on a ring above the sample's centre, each image rectified to the sample (the maps'
// grid), the flash `flash_offset_cm` beside the lens while the files, as real ones do, put the
// light at the camera.
struct FlashCaptureOptions {
  int images = 9;                                                // one at the centre, the rest on the ring
  double height_cm = 17;                                         // the cameras' height
  double ring_cm = 2.5;                                          // the ring's radius
  Eigen::Vector3d flash_offset_cm = Eigen::Vector3d(0.8, 0, 0);  // x right, y up the image, z up
  double power = 1500;                                           // the flash's, per cm² at 1 cm, each channel
  double noise = 0;                                              // relative Gaussian noise on every value
  uint64_t seed = 1;
  Status Check() const;  // every problem, naming the field
};

struct FlashCapture {
  std::vector<Image> images;                // linear radiance (per unit of the importer's model), channels R, G, B
  std::vector<Eigen::Vector3d> cameras_cm;  // as the files say (y up): the lights are put there too
  double width_cm = 0;
};

// `maps` (svbrdf_maps.h, on the sample: pixel (i, j) at ((i + 0.5 − W/2)·pixel_mm,
// (j + 0.5 − H/2)·pixel_mm), y down the image) seen under the flash.
FlashCapture RenderFlashCapture(const Image& maps, double pixel_mm, const FlashCaptureOptions& options);

}  // namespace loom::sim
