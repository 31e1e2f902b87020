#pragma once
// A heightmap on a regular grid in the sample frame (pixel (i, j) centred at
// ((i + 0.5 − W/2)·pixel_mm, (j + 0.5 − H/2)·pixel_mm), as stacks and materials lay out their
// pixels), height 0 (the holder) off the grid: the surface that the simulator renders and that
// a fitter tests cast shadows against.
// Thread-safety: immutable after construction; concurrent reads are safe.

#include <array>
#include <optional>
#include <vector>

#include <Eigen/Core>

namespace loom {

class Heightmap {
 public:
  // Shadowed() and FirstHit() skip the march across a block of this many pixels a side wherever
  // the ray is above everything the block's heights can interpolate to; and across blocks of
  // twice, four times … that side (a maximum pyramid) while the ray stays above those, so that a
  // ray far above a tall object's surface crosses it in a few steps.
  static constexpr int kDefaultBlockPx = 8;

  Heightmap() = default;
  // Row-major heights (mm), width × height of them, block_px ≥ 1 (CHECKed).
  Heightmap(std::vector<float> heights_mm, int width, int height, double pixel_mm, int block_px = kDefaultBlockPx);

  // Bilinear between pixel centres, so the surface is continuous for ray marching.
  double HeightAt(double x_mm, double y_mm) const;
  double max_height_mm() const { return max_height_mm_; }
  // Whether every height lies on one plane (a calibration target, a tile, a chart), with the grid's
  // edges high enough that the holder around it stays below that plane: Shadowed() then clears a
  // ray that does not descend towards the plane without marching it.
  bool planar() const { return plane_.has_value(); }

  // True if the surface blocks the segment from surface point `p` towards the point `light`
  // (a light below the horizon is blocked). Marches at half a pixel up to the highest point;
  // the samples it skips (off the grid, or above their block's highest point) are ones that
  // cannot be below the surface, so the answer is the full march's.
  bool Shadowed(const Eigen::Vector3d& p, const Eigen::Vector3d& light) const;

  // A horizon bound for a surface point, per sector of azimuth: in each sector, the tangent of
  // an elevation above which no light of that sector's azimuths is shadowed from the point. A
  // relief rarely rises as steeply in every direction as in its steepest, and a fit tests
  // thousands of lights from one pixel: one bound for all azimuths left half of a fabric's
  // light samples to the march, most of them unshadowed.
  struct Horizon {
    // Sectors of equal width in the "diamond angle" (a pseudo-angle monotone in the azimuth,
    // with no trigonometry to evaluate): 8 per quadrant.
    static constexpr int kSectors = 32;
    std::array<double, kSectors> slope{};
    double steepest = 0;  // the largest of them: a light above it needs no sector looked up
    // Whether `to_light` (from the point; need not be a unit vector) rises above its sector's bound.
    bool Clears(const Eigen::Vector3d& to_light) const;
  };
  // The bound for surface point `p`: the surface pixel by pixel near p, block by block further
  // out and by the highest point beyond, each element in the sectors of azimuth it can reach;
  // +∞ in every sector where no bound holds (p below the holder). Worth computing for a point
  // that many lights are tested from (a fit's pixel).
  Horizon HorizonAt(const Eigen::Vector3d& p) const;
  // Shadowed(p, light), with no march for a light that clears `horizon` (HorizonAt(p)): the same
  // answer, for a fraction of the work on gentle relief.
  bool Shadowed(const Eigen::Vector3d& p, const Eigen::Vector3d& light, const Horizon& horizon) const;

  // Where the ray from `origin` along the unit `direction` (z < 0, CHECKed) first meets the
  // surface, to 10 nm: marched at half a pixel down from the highest point and bisected, the
  // blocks it passes above skipped; the ray's point at z = 0 if it meets nothing before.
  Eigen::Vector3d FirstHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const;

 private:
  // A sample-frame point in grid coordinates: pixel centres at integers.
  Eigen::Vector2d GridPoint(double x_mm, double y_mm) const;
  // The highest height that HeightAt can return in the block holding grid point g, and how far
  // along the ray g + t·(ux, uy) (grid units per mm of ray) it leaves that block, or the
  // holder around the grid.
  struct Block {
    double max_mm;
    double t_leave;
  };
  // At pyramid level `level`: blocks of block_px_ · 2^level pixels a side.
  Block BlockAlong(const Eigen::Vector2d& g, double ux, double uy, int level) const;
  void BuildBlockMaxima();

  // z = z0 + dz_dx·x + dz_dy·y (sample frame, mm) over the grid.
  struct Plane {
    double z0, dz_dx, dz_dy;
    double At(double x_mm, double y_mm) const { return z0 + dz_dx * x_mm + dz_dy * y_mm; }
  };
  std::optional<Plane> FitPlane() const;

  std::vector<float> heights_mm_;
  int width_ = 0;
  int height_ = 0;
  double pixel_mm_ = 1;
  double max_height_mm_ = 0;
  int block_px_ = kDefaultBlockPx;
  struct Level {
    int blocks_x = 0;
    int blocks_y = 0;
    std::vector<float> max_mm;  // row-major
  };
  std::vector<Level> levels_;   // [0]: blocks of block_px_; each next one of twice the side
  std::optional<Plane> plane_;  // set where planar()
};

}  // namespace loom
