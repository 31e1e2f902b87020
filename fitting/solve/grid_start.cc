#include <algorithm>

#include <Eigen/Dense>

#include "core/geometry.h"
#include "fitting/solve/internal/grid_candidates.h"
#include "fitting/solve/pixel_fitter.h"

namespace loom::fitting {
namespace {

// For a fixed lobe shape the model is linear in the six albedos: each observation's radiance is
// (w·a_d)·Σ E·cos/π + (w·a_s)·Σ E·F·D·cos. So a shape is scored by the least-squares albedos it
// allows (negative ones clamped to 0 and the rest solved again).
struct ShapeScore {
  double cost = 0;
  Eigen::Matrix<double, 6, 1> albedos;
};

ShapeScore Score(const std::vector<PixelObservation>& observations, const WardParams<double>& shape) {
  const WardLobe<double> lobe(shape);
  Eigen::Matrix<double, 6, 6> normal = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> rhs = Eigen::Matrix<double, 6, 1>::Zero();
  std::vector<Eigen::Matrix<double, 6, 1>> rows;
  rows.reserve(observations.size());
  for (const PixelObservation& o : observations) {
    double diffuse = 0, specular = 0;
    // Every 4th light sample of a strip (weighted 4×) is plenty for choosing a start.
    const size_t step = o.lights.size() >= 16 ? 4 : 1;
    for (size_t j = 0; j < o.lights.size(); j += step) {
      const WardTerms<double> t = lobe.Terms(o.lights[j].l_local, o.v_local);
      diffuse += step * o.lights[j].irradiance * t.diffuse * t.cos_l;
      specular += step * o.lights[j].irradiance * t.specular * t.cos_l;
    }
    Eigen::Matrix<double, 6, 1> row;
    row << o.rgb_weights * diffuse, o.rgb_weights * specular;
    normal += row * row.transpose();
    rhs += row * o.radiance;
    rows.push_back(row);
  }
  ShapeScore score;
  score.albedos = internal::SolveAlbedos(normal, rhs);
  for (size_t k = 0; k < observations.size(); ++k) {
    const double r = rows[k].dot(score.albedos) - observations[k].radiance;
    score.cost += r * r;
  }
  return score;
}

std::vector<Eigen::Vector3d> CandidateNormals() {
  std::vector<Eigen::Vector3d> normals = {Eigen::Vector3d::UnitZ()};
  for (double tilt_deg : {10.0, 20.0}) {
    for (int k = 0; k < 6; ++k) normals.push_back(DirectionFromSpherical(DegToRad(tilt_deg), k * kPi / 3));
  }
  return normals;
}

struct LobeShape {
  double sigma_x, sigma_y, alpha;
};

std::vector<LobeShape> CandidateShapes() {
  const double sigmas[] = {0.03, 0.07, 0.15, 0.3};
  std::vector<LobeShape> shapes;
  for (int i = 0; i < 4; ++i) {
    shapes.push_back({sigmas[i], sigmas[i], 0});
    for (int j = i + 1; j < 4; ++j) {
      // (σx, σy, α) and (σy, σx, α + 90°) are the same lobe: σx < σy and four angles cover all.
      for (int a = 0; a < 4; ++a) shapes.push_back({sigmas[i], sigmas[j], a * kPi / 4});
    }
  }
  return shapes;
}

}  // namespace

namespace internal {

Eigen::Matrix<double, 6, 1> SolveAlbedos(Eigen::Matrix<double, 6, 6> normal, Eigen::Matrix<double, 6, 1> rhs) {
  normal.diagonal().array() += 1e-9 * normal.trace() + 1e-30;  // colour may rest on few observations
  Eigen::Matrix<double, 6, 1> albedos = normal.ldlt().solve(rhs);
  if ((albedos.array() < 0).any()) {
    // One active-set pass: fix the negative ones at 0 and solve for the rest.
    for (int i = 0; i < 6; ++i) {
      if (albedos[i] >= 0) continue;
      normal.row(i).setZero();
      normal.col(i).setZero();
      normal(i, i) = 1;
      rhs[i] = 0;
    }
    albedos = normal.ldlt().solve(rhs).cwiseMax(0.0);
  }
  return albedos.cwiseMin(kMaxAlbedo);
}

std::vector<WardParams<double>> Best(std::vector<std::pair<double, WardParams<double>>> scored, int count) {
  const size_t keep = std::min(scored.size(), static_cast<size_t>(std::max(count, 1)));
  std::partial_sort(scored.begin(), scored.begin() + keep, scored.end(),
                    [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<WardParams<double>> best;
  for (size_t i = 0; i < keep; ++i) best.push_back(scored[i].second);
  return best;
}

std::vector<WardParams<double>> GridCandidates(double f0, bool isotropic_only) {
  static const std::vector<Eigen::Vector3d> normals = CandidateNormals();
  static const std::vector<LobeShape> shapes = CandidateShapes();
  std::vector<WardParams<double>> candidates;
  for (const Eigen::Vector3d& n : normals) {
    for (const LobeShape& shape : shapes) {
      if (isotropic_only && shape.sigma_x != shape.sigma_y) continue;
      WardParams<double> candidate;
      candidate.n_s = n;
      candidate.sigma_x = shape.sigma_x;
      candidate.sigma_y = shape.sigma_y;
      candidate.alpha = shape.alpha;
      candidate.f0 = f0;
      candidates.push_back(candidate);
    }
  }
  return candidates;
}

}  // namespace internal

std::vector<WardParams<double>> GridInitialParams(const std::vector<PixelObservation>& observations, double f0, int count) {
  std::vector<PixelObservation> usable;
  for (const PixelObservation& o : observations) {
    if (!std::isnan(o.radiance) && !o.lights.empty()) usable.push_back(o);
  }
  std::vector<std::pair<double, WardParams<double>>> scored;
  for (WardParams<double> candidate : internal::GridCandidates(f0)) {
    const ShapeScore score = Score(usable, candidate);
    candidate.a_d = score.albedos.head<3>();
    candidate.a_s = score.albedos.tail<3>();
    scored.push_back({score.cost, candidate});
  }
  return internal::Best(std::move(scored), count);
}

}  // namespace loom::fitting
