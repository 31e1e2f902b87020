#pragma once
// A heightmap on a regular grid in the sample frame (pixel (i, j) centred at
// ((i + 0.5 − W/2)·pixel_mm, (j + 0.5 − H/2)·pixel_mm), as stacks and materials lay out their
// pixels), height 0 (the holder) off the grid: the surface that the simulator renders and that
// a fitter tests cast shadows against.
// Thread-safety: immutable after construction; concurrent reads are safe.

#include <vector>

#include <Eigen/Core>

namespace loom {

class Heightmap {
 public:
  Heightmap() = default;
  // Row-major heights (mm), width × height of them (CHECKed).
  Heightmap(std::vector<float> heights_mm, int width, int height, double pixel_mm);

  // Bilinear between pixel centres, so the surface is continuous for ray marching.
  double HeightAt(double x_mm, double y_mm) const;
  double max_height_mm() const { return max_height_mm_; }

  // True if the surface blocks the segment from surface point `p` towards the point `light`
  // (a light below the horizon is blocked). Marches at half a pixel up to the highest point.
  bool Shadowed(const Eigen::Vector3d& p, const Eigen::Vector3d& light) const;

 private:
  std::vector<float> heights_mm_;
  int width_ = 0;
  int height_ = 0;
  double pixel_mm_ = 1;
  double max_height_mm_ = 0;
};

}  // namespace loom
