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
  uint64_t seed = 1;
  Status Check() const;  // every problem, naming the field
};

struct ObjectCapture {
  std::vector<Image> images;                      // linear radiance, channels R, G, B, one per light
  std::vector<Eigen::Vector3d> light_directions;  // unit, x right, y up, z towards the camera
  Image mask;                                     // channel "mask": 1 on the object, 0 off it
  Image normals;                                  // channels X, Y, Z: x right, y up, z towards the camera; 0 off it
  Image truth;                                    // SVBRDF maps on the image's grid (stack frame: y down); NaN off it
};

// Irradiance 1 from every light; radiance = (a_d/π + a_s F D)(n·l) as the fitters model it.
ObjectCapture RenderObjectCapture(const ObjectCaptureOptions& options);

}  // namespace loom::sim
