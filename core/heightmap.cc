#include "core/heightmap.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/check.h"

namespace loom {
namespace {

// A sample this far below the surface counts as blocked: the surface points that rays start
// from are themselves bilinear interpolations, a little off the march's own.
constexpr double kShadowToleranceMm = 1e-4;
// A grid is planar where every height is within this of one plane (a float's rounding of a
// height of 100 mm is 4e-6 mm)...
constexpr double kPlanarToleranceMm = 1e-5;
// ... and a point counts as on that plane within this (FirstHit's bisection stops within 1e-5 mm
// along its ray). The two, and the bilinear interpolation's rounding, stay well inside
// kShadowToleranceMm, which is why a planar grid's shortcut gives the march's answer.
constexpr double kOnPlaneSlackMm = 2e-5;

}  // namespace

Heightmap::Heightmap(std::vector<float> heights_mm, int width, int height, double pixel_mm, int block_px)
    : heights_mm_(std::move(heights_mm)), width_(width), height_(height), pixel_mm_(pixel_mm), block_px_(block_px) {
  LOOM_CHECK(heights_mm_.size() == static_cast<size_t>(width) * height) << "heightmap size";
  LOOM_CHECK(pixel_mm > 0) << "heightmap pixel size";
  LOOM_CHECK(block_px >= 1) << "heightmap block size";
  // The holder (height 0) surrounds the grid, so the highest point is at least 0.
  max_height_mm_ = std::max(0.0f, heights_mm_.empty() ? 0.0f : *std::max_element(heights_mm_.begin(), heights_mm_.end()));
  BuildBlockMaxima();
  plane_ = FitPlane();
}

// The plane through the corner pixels (0, 0), (W − 1, 0) and (0, H − 1), if every pixel lies on
// it and the lowest pixel is at least one pixel's rise of the plane above the holder. Then, within
// a pixel of the grid, HeightAt blends pixels on the plane with the holder's 0, each no higher
// than the plane's extension there, so the surface is nowhere above the plane; beyond, the
// holder's 0 lies below any surface point a ray could start from.
std::optional<Heightmap::Plane> Heightmap::FitPlane() const {
  if (width_ < 2 || height_ < 2) return std::nullopt;
  const auto height = [&](int x, int y) -> double { return heights_mm_[static_cast<size_t>(y) * width_ + x]; };
  const auto centre_x = [&](int x) { return (x + 0.5 - width_ / 2.0) * pixel_mm_; };
  const auto centre_y = [&](int y) { return (y + 0.5 - height_ / 2.0) * pixel_mm_; };
  Plane plane{0, (height(width_ - 1, 0) - height(0, 0)) / ((width_ - 1) * pixel_mm_),
              (height(0, height_ - 1) - height(0, 0)) / ((height_ - 1) * pixel_mm_)};
  plane.z0 = height(0, 0) - plane.dz_dx * centre_x(0) - plane.dz_dy * centre_y(0);
  const double lowest_allowed = (std::abs(plane.dz_dx) + std::abs(plane.dz_dy)) * pixel_mm_;
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const double z = height(x, y);
      if (std::abs(z - plane.At(centre_x(x), centre_y(y))) > kPlanarToleranceMm || z < lowest_allowed) return std::nullopt;
    }
  }
  return plane;
}

// Grid coordinates: pixel centres at integers. HeightAt reads pixels floor(g) and floor(g) + 1,
// so only g ∈ [−1, W) × [−1, H) can be above or below 0. Block (bx, by) of side B covers
// g ∈ [bx·B − 1, (bx + 1)·B − 1) and reads pixels bx·B − 1 … (bx + 1)·B − 1, the holder's 0
// where those lie off the grid. A block of side 2B covers its four blocks of side B (a missing
// one lies off the grid: the holder's 0).
void Heightmap::BuildBlockMaxima() {
  Level& first = levels_.emplace_back();
  first.blocks_x = (width_ + 1 + block_px_ - 1) / block_px_;
  first.blocks_y = (height_ + 1 + block_px_ - 1) / block_px_;
  first.max_mm.assign(static_cast<size_t>(first.blocks_x) * first.blocks_y, 0.0f);
  for (int by = 0; by < first.blocks_y; ++by) {
    for (int bx = 0; bx < first.blocks_x; ++bx) {
      const int x_lo = bx * block_px_ - 1, x_hi = x_lo + block_px_;
      const int y_lo = by * block_px_ - 1, y_hi = y_lo + block_px_;
      const bool reads_the_holder = x_lo < 0 || y_lo < 0 || x_hi >= width_ || y_hi >= height_;
      float highest = reads_the_holder ? 0.0f : -std::numeric_limits<float>::infinity();
      for (int y = std::max(y_lo, 0); y <= std::min(y_hi, height_ - 1); ++y) {
        for (int x = std::max(x_lo, 0); x <= std::min(x_hi, width_ - 1); ++x) {
          highest = std::max(highest, heights_mm_[static_cast<size_t>(y) * width_ + x]);
        }
      }
      first.max_mm[static_cast<size_t>(by) * first.blocks_x + bx] = highest;
    }
  }
  while (levels_.back().blocks_x > 1 || levels_.back().blocks_y > 1) {
    const Level& below = levels_.back();
    Level above{(below.blocks_x + 1) / 2, (below.blocks_y + 1) / 2, {}};
    above.max_mm.assign(static_cast<size_t>(above.blocks_x) * above.blocks_y, 0.0f);
    for (int by = 0; by < above.blocks_y; ++by) {
      for (int bx = 0; bx < above.blocks_x; ++bx) {
        const bool off_the_grid = 2 * bx + 1 >= below.blocks_x || 2 * by + 1 >= below.blocks_y;
        float highest = off_the_grid ? 0.0f : -std::numeric_limits<float>::infinity();
        for (int y = 2 * by; y <= std::min(2 * by + 1, below.blocks_y - 1); ++y) {
          for (int x = 2 * bx; x <= std::min(2 * bx + 1, below.blocks_x - 1); ++x) {
            highest = std::max(highest, below.max_mm[static_cast<size_t>(y) * below.blocks_x + x]);
          }
        }
        above.max_mm[static_cast<size_t>(by) * above.blocks_x + bx] = highest;
      }
    }
    levels_.push_back(std::move(above));
  }
}

Eigen::Vector2d Heightmap::GridPoint(double x_mm, double y_mm) const {
  return {x_mm / pixel_mm_ + width_ / 2.0 - 0.5, y_mm / pixel_mm_ + height_ / 2.0 - 0.5};
}

double Heightmap::HeightAt(double x_mm, double y_mm) const {
  const Eigen::Vector2d g = GridPoint(x_mm, y_mm);
  const double gx = g.x(), gy = g.y();
  const int x0 = static_cast<int>(std::floor(gx));
  const int y0 = static_cast<int>(std::floor(gy));
  const double fx = gx - x0;
  const double fy = gy - y0;
  const auto at = [&](int x, int y) -> double {
    if (x < 0 || y < 0 || x >= width_ || y >= height_) return 0.0;
    return heights_mm_[static_cast<size_t>(y) * width_ + x];
  };
  return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) + fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
}

Heightmap::Block Heightmap::BlockAlong(const Eigen::Vector2d& g, double ux, double uy, int level) const {
  constexpr double kNever = std::numeric_limits<double>::infinity();
  const double gx = g.x(), gy = g.y();
  const double w = width_, h = height_;
  if (gx < -1 || gy < -1 || gx >= w || gy >= h) {
    // Off the grid the surface is the holder, at 0, until the ray enters the grid, if it does.
    struct Span {
      double in, out;
    };
    const auto slab = [](double g, double u, double lo, double hi) -> Span {
      if (u == 0) return g >= lo && g < hi ? Span{-kNever, kNever} : Span{kNever, -kNever};
      const double a = (lo - g) / u, b = (hi - g) / u;
      return {std::min(a, b), std::max(a, b)};
    };
    const Span x = slab(gx, ux, -1, w), y = slab(gy, uy, -1, h);
    const double t_in = std::max({x.in, y.in, 0.0});
    return {0.0, t_in < std::min(x.out, y.out) ? t_in : kNever};
  }
  // How long the ray stays in [lo, hi) along one axis.
  const auto leave = [](double g, double u, double lo, double hi) {
    return u > 0 ? (hi - g) / u : u < 0 ? (g - lo) / -u : kNever;
  };
  const Level& blocks = levels_[level];
  const int side = block_px_ << level;
  const int bx = static_cast<int>(std::floor((gx + 1) / side));
  const int by = static_cast<int>(std::floor((gy + 1) / side));
  const double x_lo = bx * side - 1.0, y_lo = by * side - 1.0;
  const double t_leave = std::min(leave(gx, ux, x_lo, std::min(x_lo + side, w)), leave(gy, uy, y_lo, std::min(y_lo + side, h)));
  return {blocks.max_mm[static_cast<size_t>(by) * blocks.blocks_x + bx], t_leave};
}

// The march samples the ray at t = t_first + k·dt. Where the ray is above a block (rising: at
// the sample; descending: where it leaves the block), every sample up to the block's edge is
// skipped and the next block looked at is one level coarser; where it is not, one level finer,
// down to the finest blocks, whose samples the surface decides one by one.
bool Heightmap::Shadowed(const Eigen::Vector3d& p, const Eigen::Vector3d& light) const {
  const Eigen::Vector3d s = (light - p).normalized();
  if (s.z() <= 0) return true;
  // On or above a planar surface, a ray that does not descend towards its plane stays above it
  // and so above the whole surface (FitPlane): no march. Those are the long marches on a
  // calibration target, every one up to the highest point (the target's 29-LED steps were most of
  // tac7's calibration scan, two thirds of it in marches).
  if (plane_ && p.z() - plane_->At(p.x(), p.y()) >= -kOnPlaneSlackMm && s.z() >= plane_->dz_dx * s.x() + plane_->dz_dy * s.y()) {
    return false;
  }
  const double t_max = (max_height_mm_ - p.z()) / s.z();
  const double horizontal = std::max(s.head<2>().norm(), 1e-9);
  const double dt = 0.5 * pixel_mm_ / horizontal;
  const double ux = s.x() / pixel_mm_, uy = s.y() / pixel_mm_;  // grid units per mm along the ray
  const double t_first = std::min(dt, t_max) * 0.5;
  const int top = static_cast<int>(levels_.size()) - 1;
  int level = 0;
  for (double k = 0, t = t_first; t < t_max;) {
    const Eigen::Vector3d q = p + t * s;
    const Block block = BlockAlong(GridPoint(q.x(), q.y()), ux, uy, level);
    const double t_leave = t + block.t_leave;
    if (q.z() >= block.max_mm - kShadowToleranceMm) {
      // The ray rises, so every sample until it leaves the block is above the block too.
      if (t_leave >= t_max) return false;
      k = std::max(k + 1, std::ceil((t_leave - t_first) / dt));
      t = t_first + k * dt;
      level = std::min(level + 1, top);
      continue;
    }
    if (level > 0) {
      --level;
      continue;
    }
    // Below the finest block's top: the surface decides every sample until the ray leaves it.
    do {
      const Eigen::Vector3d r = p + t * s;
      if (r.z() < HeightAt(r.x(), r.y()) - kShadowToleranceMm) return true;
      t = t_first + ++k * dt;
    } while (t < t_leave && t < t_max);
  }
  return false;
}

// Why the bound holds. Shadowed samples the ray at horizontal distances ρ > 0 from p, along the
// light's azimuth φ; a sample at height z_p + m·ρ (m the ray's slope) is blocked where it is
// below the surface. For p on or above the surface (z_p ≥ HeightAt(p)), bounds on the surface
// cover every sample. A sample at azimuth φ lies only in regions of the grid that some ray from
// p at azimuth φ enters, so each region counts only in the sectors of the azimuths that its
// rectangle spans as seen from p. For a near radius r (each of kNearRadiiPx):
//  - within r of p, the surface rises from HeightAt(p) along φ at most at the steepest rise
//    along φ of the bilinear patches (cells between pixel centres) crossed: a patch whose slopes
//    lie in [x_lo, x_hi] × [y_lo, y_hi] rises along u at most at u · (the corner of that box u
//    points to). No sample there is blocked if m is larger;
//  - beyond r, HeightAt within a patch is at most its highest corner, and within a block at
//    most the block's maximum; a region nowhere above h, at distance d from p, blocks no ray
//    with m ≥ (h − z_p) / max(r, d). Patches in the 3 × 3 blocks around p's are taken one by
//    one, blocks up to kBlockRings away by their maxima, the rest by the highest point in
//    every direction.
// Each r gives a bound; each sector keeps the least (a short r suits a steep patch under p, a
// long one a bump just beyond it). Half the march's tolerance is kept as a margin for the
// march's own rounding.
namespace {

constexpr int kSectors = Heightmap::Horizon::kSectors;
// The radii within which the surface is bounded by its patches' rises, beyond by their heights.
constexpr std::array<double, 4> kNearRadiiPx = {0.75, 1.5, 2.25, 3};
constexpr double kSectorsPerUnit = kSectors / 4.0;  // diamond angles run over [0, 4)

// The diamond angle of direction (x, y): [0, 4), increasing with atan2(y, x) taken in [0, 2π),
// a quarter turn per unit; 0 for (0, 0).
double DiamondAngle(double x, double y) {
  if (x == 0 && y == 0) return 0;
  if (y >= 0) return x >= 0 ? y / (x + y) : 1 - x / (y - x);
  return x < 0 ? 2 - y / (-x - y) : 3 + x / (x - y);
}

int SectorOf(double x, double y) { return std::min(kSectors - 1, static_cast<int>(DiamondAngle(x, y) * kSectorsPerUnit)); }

// The unit directions at each sector's ends (no sector crosses an axis, so the signs of a
// direction's components are its quadrant's throughout a sector).
struct SectorEnds {
  std::array<Eigen::Vector2d, kSectors + 1> direction;
  SectorEnds() {
    for (int k = 0; k <= kSectors; ++k) {
      const double d = k / kSectorsPerUnit;
      const int quadrant = std::min(3, static_cast<int>(d));
      const double f = d - quadrant;
      const Eigen::Vector2d v = quadrant == 0   ? Eigen::Vector2d(1 - f, f)
                                : quadrant == 1 ? Eigen::Vector2d(-f, 1 - f)
                                : quadrant == 2 ? Eigen::Vector2d(f - 1, -f)
                                                : Eigen::Vector2d(f, f - 1);
      direction[k] = v.normalized();
    }
  }
};

// The steepest rise along any azimuth of sector k across a bilinear patch whose slopes along x
// and y lie in [x_lo, x_hi] and [y_lo, y_hi]: max over the sector's directions u of u · D, D the
// corner of the slopes' box that u's quadrant points to.
double SteepestRise(int k, double x_lo, double x_hi, double y_lo, double y_hi) {
  static const SectorEnds ends;
  const Eigen::Vector2d& a = ends.direction[k];
  const Eigen::Vector2d& b = ends.direction[k + 1];
  const Eigen::Vector2d mid = a + b;  // its signs are the sector's
  const Eigen::Vector2d d(mid.x() >= 0 ? x_hi : x_lo, mid.y() >= 0 ? y_hi : y_lo);
  // u · D peaks at D's own direction if that lies in the sector, else at one of its ends.
  const bool inside = a.x() * d.y() - a.y() * d.x() >= 0 && d.x() * b.y() - d.y() * b.x() >= 0 && d.dot(mid) > 0;
  return inside ? d.norm() : std::max(a.dot(d), b.dot(d));
}

// Calls visit(k) for every sector k that the diamond angles [lo, hi] touch (hi − lo ≥ 4: all
// of them), with a little to spare at the ends for rounding.
template <typename Visit>
void ForSectors(double lo, double hi, Visit visit) {
  constexpr double kSpare = 1e-9;
  const int first = static_cast<int>(std::floor((lo - kSpare) * kSectorsPerUnit));
  const int last = hi - lo >= 4 ? first + kSectors - 1 : static_cast<int>(std::floor((hi + kSpare) * kSectorsPerUnit));
  for (int k = first; k <= std::min(last, first + kSectors - 1); ++k) visit(((k % kSectors) + kSectors) % kSectors);
}

// Raises the bound to `slope` in the sectors of the diamond angles [lo, hi].
void Raise(Heightmap::Horizon& horizon, double lo, double hi, double slope) {
  ForSectors(lo, hi, [&](int k) { horizon.slope[k] = std::max(horizon.slope[k], slope); });
}

// The diamond angles of the azimuths from the origin into an axis-aligned rectangle that does
// not hold it (its extremes are at its corners, within half a turn of its centre's).
std::pair<double, double> RectangleAzimuths(double x_lo, double y_lo, double side) {
  const double centre = DiamondAngle(x_lo + side / 2, y_lo + side / 2);
  double lo = 0, hi = 0;
  for (const double x : {x_lo, x_lo + side}) {
    for (const double y : {y_lo, y_lo + side}) {
      double delta = DiamondAngle(x, y) - centre;
      delta -= 4 * std::round(delta / 4);
      lo = std::min(lo, delta), hi = std::max(hi, delta);
    }
  }
  return {centre + lo, centre + hi};
}

}  // namespace

bool Heightmap::Horizon::Clears(const Eigen::Vector3d& to_light) const {
  const double horizontal = to_light.head<2>().norm();
  return to_light.z() > steepest * horizontal || to_light.z() > slope[SectorOf(to_light.x(), to_light.y())] * horizontal;
}

Heightmap::Horizon Heightmap::HorizonAt(const Eigen::Vector3d& p) const {
  constexpr int kPatchRings = 1;
  constexpr int kBlockRings = 4;
  const double margin = kShadowToleranceMm / 2;
  Horizon horizon;
  // Below the surface (or the holder) no bound holds: the march decides.
  if (p.z() < -margin || p.z() < HeightAt(p.x(), p.y()) - margin) {
    horizon.slope.fill(std::numeric_limits<double>::infinity());
    horizon.steepest = std::numeric_limits<double>::infinity();
    return horizon;
  }
  const Eigen::Vector2d g = GridPoint(p.x(), p.y());
  const auto pixel_height = [&](int x, int y) -> double {
    return x < 0 || y < 0 || x >= width_ || y >= height_ ? 0.0 : heights_mm_[static_cast<size_t>(y) * width_ + x];
  };
  // Not std::hypot: its guard against overflow, which distances of a few pixels cannot reach,
  // cost 1 % of a tac7-mini fit in libm (perf).
  const auto distance_to = [&](double x_lo, double y_lo, double side) {
    const double dx = std::max({x_lo - g.x(), g.x() - (x_lo + side), 0.0});
    const double dy = std::max({y_lo - g.y(), g.y() - (y_lo + side), 0.0});
    return std::sqrt(dx * dx + dy * dy);
  };
  // A region at distance_px ≥ `near_px` from p, nowhere above `height`, blocks no ray rising
  // more steeply than this.
  const auto slope_over = [&](double height, double distance_px, double near_px) {
    return (height - margin - p.z()) / (std::max(near_px, distance_px) * pixel_mm_);
  };
  // The patches (cells [x, x + 1] × [y, y + 1] between pixel centres) of the blocks within
  // kPatchRings of p's, each in the sectors of the azimuths it spans. Every near radius gives a
  // bound of its own: rises within it, heights beyond it; each sector keeps the least.
  std::array<std::array<double, kSectors>, kNearRadiiPx.size()> rise{}, height{};
  const int bx = static_cast<int>(std::floor((g.x() + 1) / block_px_));
  const int by = static_cast<int>(std::floor((g.y() + 1) / block_px_));
  for (int y = (by - kPatchRings) * block_px_ - 1; y < (by + kPatchRings + 1) * block_px_ - 1; ++y) {
    for (int x = (bx - kPatchRings) * block_px_ - 1; x < (bx + kPatchRings + 1) * block_px_ - 1; ++x) {
      const double h00 = pixel_height(x, y), h10 = pixel_height(x + 1, y);
      const double h01 = pixel_height(x, y + 1), h11 = pixel_height(x + 1, y + 1);
      const double highest = std::max({h00, h10, h01, h11});
      const double distance = distance_to(x, y, 1);
      const bool near = distance < kNearRadiiPx.back();
      if (!near && highest - margin <= p.z()) continue;
      // (px) Nearer, a patch's azimuths span half a turn or more: all sectors.
      constexpr double kOnTheEdge = 1e-3;
      const auto [lo, hi] = distance < kOnTheEdge ? std::pair<double, double>{0, 4} : RectangleAzimuths(x - g.x(), y - g.y(), 1);
      const double x_lo = std::min(h10 - h00, h11 - h01) / pixel_mm_, x_hi = std::max(h10 - h00, h11 - h01) / pixel_mm_;
      const double y_lo = std::min(h01 - h00, h11 - h10) / pixel_mm_, y_hi = std::max(h01 - h00, h11 - h10) / pixel_mm_;
      ForSectors(lo, hi, [&](int k) {
        const double steepest = near ? SteepestRise(k, x_lo, x_hi, y_lo, y_hi) : 0.0;
        for (size_t r = 0; r < kNearRadiiPx.size(); ++r) {
          if (distance < kNearRadiiPx[r]) rise[r][k] = std::max(rise[r][k], steepest);
          // Its points beyond the radius, if it has any.
          if (highest - margin > p.z() && distance + std::sqrt(2.0) >= kNearRadiiPx[r]) {
            height[r][k] = std::max(height[r][k], slope_over(highest, distance, kNearRadiiPx[r]));
          }
        }
      });
    }
  }
  for (int k = 0; k < kSectors; ++k) {
    horizon.slope[k] = std::numeric_limits<double>::infinity();
    for (size_t r = 0; r < kNearRadiiPx.size(); ++r)
      horizon.slope[k] = std::min(horizon.slope[k], std::max(rise[r][k], height[r][k]));
  }
  // Further out, blocks by their maxima, then the highest point.
  for (int j = std::max(0, by - kBlockRings); j <= std::min(levels_[0].blocks_y - 1, by + kBlockRings); ++j) {
    for (int i = std::max(0, bx - kBlockRings); i <= std::min(levels_[0].blocks_x - 1, bx + kBlockRings); ++i) {
      if (std::abs(i - bx) <= kPatchRings && std::abs(j - by) <= kPatchRings) continue;
      const double h = levels_[0].max_mm[static_cast<size_t>(j) * levels_[0].blocks_x + i];
      if (h - margin <= p.z()) continue;
      const double x_lo = i * block_px_ - 1.0, y_lo = j * block_px_ - 1.0;  // the grid points it covers: from x_lo, y_lo
      const auto [lo, hi] = RectangleAzimuths(x_lo - g.x(), y_lo - g.y(), block_px_);
      Raise(horizon, lo, hi, slope_over(h, distance_to(x_lo, y_lo, block_px_), kNearRadiiPx.back()));
    }
  }
  // Every pixel beyond lies more than kBlockRings blocks from p.
  if (max_height_mm_ - margin > p.z()) {
    Raise(horizon, 0, 4, slope_over(max_height_mm_, kBlockRings * block_px_, kNearRadiiPx.back()));
  }
  horizon.steepest = *std::max_element(horizon.slope.begin(), horizon.slope.end());
  return horizon;
}

bool Heightmap::Shadowed(const Eigen::Vector3d& p, const Eigen::Vector3d& light, const Horizon& horizon) const {
  return !horizon.Clears(light - p) && Shadowed(p, light);
}

Eigen::Vector3d Heightmap::FirstHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) const {
  LOOM_CHECK(direction.z() < 0) << "FirstHit needs a descending ray";
  const double t_top = std::max(0.0, (max_height_mm_ + 1e-6 - origin.z()) / direction.z());
  const double t_bottom = -origin.z() / direction.z();
  if (max_height_mm_ <= 0) return origin + t_bottom * direction;
  const double dt = 0.5 * pixel_mm_ / std::max(direction.head<2>().norm(), 1e-9);
  const double ux = direction.x() / pixel_mm_, uy = direction.y() / pixel_mm_;
  const auto below_surface = [&](double t) {
    const Eigen::Vector3d p = origin + t * direction;
    return p.z() <= HeightAt(p.x(), p.y());
  };
  const auto sample = [&](double k) { return k == 0 ? t_top : t_top + k * dt; };
  const int top = static_cast<int>(levels_.size()) - 1;
  int level = 0;
  for (double k = 1;;) {
    const double tt = std::min(sample(k), t_bottom);
    if (tt < t_bottom) {
      const Eigen::Vector3d p = origin + tt * direction;
      const Block block = BlockAlong(GridPoint(p.x(), p.y()), ux, uy, level);
      const double t_end = std::min(tt + block.t_leave, t_bottom);
      if (origin.z() + t_end * direction.z() >= block.max_mm) {
        // The ray descends, so every sample before it leaves the block is above the block.
        k = std::max(k + 1, std::ceil((t_end - t_top) / dt));
        level = std::min(level + 1, top);
        continue;
      }
      if (level > 0) {
        --level;
        continue;
      }
    }
    if (below_surface(tt)) {
      // Above at lo, below at hi; bisected to 10 nm, well inside Shadowed's 0.1 µm tolerance
      // (a near-vertical ray's first step can span the whole height range).
      double lo = std::min(sample(k - 1), t_bottom), hi = tt;
      while (hi - lo > 1e-5) {
        const double mid = 0.5 * (lo + hi);
        (below_surface(mid) ? hi : lo) = mid;
      }
      return origin + hi * direction;
    }
    if (tt >= t_bottom) return origin + t_bottom * direction;
    ++k;
  }
}

}  // namespace loom
