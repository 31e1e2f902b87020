// The GD10 Ward model against its reference values (testdata/), plus the properties every
// loom BRDF must have: non-negativity, reciprocity, energy ≤ 1, derivatives, symmetries.
#include "fitting/model/ward_gd10.h"
#include "core/testing/build_tree.h"

#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

namespace loom::fitting {
namespace {

using Json = nlohmann::json;

const Json& Reference() {
  static const Json reference = [] {
    const std::string path = loom::testing::SourceDir() + "/fitting/model/testdata/ward_gd10_reference.json";
    std::ifstream in(path);
    if (!in) throw std::runtime_error("cannot open " + path);
    return Json::parse(in);
  }();
  return reference;
}

Eigen::Vector3d Vec(const Json& j) { return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()}; }

WardParams<double> ParamsOf(const Json& c) {
  const Json& p = c["params"];
  WardParams<double> params;
  params.n_s = Vec(p["n_s"]);
  params.a_d = Vec(p["a_d"]);
  params.a_s = Vec(p["a_s"]);
  params.sigma_x = p["sigma_x"].get<double>();
  params.sigma_y = p["sigma_y"].get<double>();
  params.alpha = p["alpha"].get<double>();
  params.f0 = p["F0"].get<double>();
  return params;
}

// |actual − expected| ≤ tolerance · |expected|, and exactly 0 where expected is 0.
template <typename T>
void ExpectRelativeNear(const Vec3<T>& actual, const Eigen::Vector3d& expected, double tolerance, const std::string& what) {
  for (int i = 0; i < 3; ++i) {
    const double a = static_cast<double>(actual[i]);
    if (expected[i] == 0.0) {
      EXPECT_EQ(a, 0.0) << what << " channel " << i;
    } else {
      EXPECT_LE(std::abs(a - expected[i]), tolerance * std::abs(expected[i]))
          << what << " channel " << i << ": " << a << " vs " << expected[i];
    }
  }
}

template <typename T>
void CheckAllReferenceCases(double tolerance) {
  const Json& cases = Reference()["cases"];
  ASSERT_EQ(cases.size(), 195u);
  int zero_cases = 0;
  for (const Json& c : cases) {
    const WardParams<T> params = ParamsOf(c).Cast<T>();
    const Vec3<T> l = Vec(c["l"]).cast<T>();
    const Vec3<T> v = Vec(c["v"]).cast<T>();
    const std::string what = "case " + std::to_string(c["id"].get<int>()) + " (" + c["category"].get<std::string>() + ")";
    ExpectRelativeNear(EvaluateWard(params, l, v), Vec(c["f"]), tolerance, what + " f");
    ExpectRelativeNear(EvaluateWardCos(params, l, v), Vec(c["f_cos"]), tolerance, what + " f_cos");
    if (!c["valid"].get<bool>()) {
      ++zero_cases;
      EXPECT_TRUE(EvaluateWard(params, l, v).isZero(0)) << what;
    }
  }
  EXPECT_EQ(zero_cases, 4);
}

TEST(WardGd10Test, AllReferenceCasesDouble) { CheckAllReferenceCases<double>(1e-6); }

TEST(WardGd10Test, AllReferenceCasesFloat) { CheckAllReferenceCases<float>(1e-4); }

TEST(WardGd10Test, IntermediateTermsMatchReference) {
  for (const Json& c : Reference()["cases"]) {
    if (!c["valid"].get<bool>()) continue;
    const WardLobe<double> lobe(ParamsOf(c));
    const std::string what = "case " + std::to_string(c["id"].get<int>());
    EXPECT_TRUE(lobe.frame().t.isApprox(Vec(c["frame_t"]), 1e-12)) << what;
    EXPECT_TRUE(lobe.frame().b.isApprox(Vec(c["frame_b"]), 1e-12)) << what;
    const WardTerms<double> terms = lobe.Terms(Vec(c["l"]), Vec(c["v"]));
    const double f = c["F"].get<double>();
    const double lobe_value = c["spec_lobe"].get<double>();
    EXPECT_NEAR(terms.specular, f * lobe_value, 1e-9 * f * lobe_value) << what;
    EXPECT_NEAR(terms.cos_l, c["cos_theta_l"].get<double>(), 1e-15) << what;
  }
}

TEST(WardGd10Test, ClosedFormAtMirrorDirection) {
  // n_s = z, exact mirror direction: D = 1 / (4π σx σy cos² θ_v).
  WardParams<double> params;
  params.a_s = {1, 1, 1};
  params.sigma_x = 0.07;
  params.sigma_y = 0.3;
  params.alpha = 0.4;
  for (double theta : {0.0, 0.3, 0.9, 1.4}) {
    const Eigen::Vector3d v = DirectionFromSpherical(theta, 0.7);
    const Eigen::Vector3d l(-v.x(), -v.y(), v.z());
    const double expected = 1.0 / (4 * kPi * 0.07 * 0.3 * std::cos(theta) * std::cos(theta));
    EXPECT_NEAR(EvaluateWard(params, l, v).x(), expected, 1e-12 * expected);
  }
}

WardParams<double> RandomParams(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  WardParams<double> p;
  p.n_s = DirectionFromSpherical(0.5 * unit(rng), 2 * kPi * unit(rng));
  p.a_d = {unit(rng), unit(rng), unit(rng)};
  p.a_s = {unit(rng), unit(rng), unit(rng)};
  p.sigma_x = 0.02 + 0.6 * unit(rng);
  p.sigma_y = 0.02 + 0.6 * unit(rng);
  p.alpha = kPi * (unit(rng) - 0.5);
  p.f0 = unit(rng);
  return p;
}

Eigen::Vector3d RandomUpperDirection(std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  return DirectionFromSpherical(std::acos(unit(rng)), 2 * kPi * unit(rng));
}

TEST(WardGd10Test, NonNegativeAndReciprocal) {
  std::mt19937 rng(42);
  int nonzero = 0;
  for (int i = 0; i < 20000; ++i) {
    const WardParams<double> params = RandomParams(rng);
    const Eigen::Vector3d l = RandomUpperDirection(rng);
    const Eigen::Vector3d v = RandomUpperDirection(rng);
    const Eigen::Vector3d f_lv = EvaluateWard(params, l, v);
    const Eigen::Vector3d f_vl = EvaluateWard(params, v, l);
    ASSERT_GE(f_lv.minCoeff(), 0.0);
    ASSERT_TRUE(f_lv.allFinite());
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(f_lv[k], f_vl[k], 1e-12 * std::max(1.0, f_lv[k]));
    if (f_lv.maxCoeff() > 0) ++nonzero;
  }
  EXPECT_GT(nonzero, 15000);  // the test exercised the lobe, not only the zero cases
}

TEST(WardGd10Test, SigmaSwapWithQuarterTurnIsTheSameBrdf) {
  // Exact for n_s = z. For a tilted n_s, t0 is projected onto the tangent plane, and the
  // projections of t0(α) and t0(α + π/2) are no longer orthogonal, so the swap is only approximate.
  std::mt19937 rng(7);
  for (int i = 0; i < 2000; ++i) {
    WardParams<double> params = RandomParams(rng);
    params.n_s = Eigen::Vector3d::UnitZ();
    WardParams<double> swapped = params;
    std::swap(swapped.sigma_x, swapped.sigma_y);
    swapped.alpha = params.alpha + kPi / 2;
    const Eigen::Vector3d l = RandomUpperDirection(rng);
    const Eigen::Vector3d v = RandomUpperDirection(rng);
    const Eigen::Vector3d a = EvaluateWard(params, l, v);
    const Eigen::Vector3d b = EvaluateWard(swapped, l, v);
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(a[k], b[k], 1e-10 * std::max(1.0, a[k]));
  }
}

TEST(WardGd10Test, BatchedEqualsSingle) {
  std::mt19937 rng(3);
  std::vector<WardParams<double>> pixels = {RandomParams(rng), RandomParams(rng), RandomParams(rng)};
  const size_t n = 50;
  std::vector<Eigen::Vector3d> l, v;
  for (size_t i = 0; i < pixels.size() * n; ++i) {
    l.push_back(RandomUpperDirection(rng));
    v.push_back(RandomUpperDirection(rng));
  }
  std::vector<Eigen::Vector3d> out(l.size());
  EvaluateSvbrdfCosBatch<double>(pixels, n, l, v, out);
  for (size_t i = 0; i < out.size(); ++i) {
    ASSERT_EQ(out[i], EvaluateWardCos(pixels[i / n], l[i], v[i])) << i;
  }
  std::vector<Eigen::Vector3d> short_out(3);
  EXPECT_THROW(EvaluateSvbrdfCosBatch<double>(pixels, n, l, v, short_out), CheckError);
}

// ---- Energy: the directional-albedo table of the reference, by our own quadrature ----

// A(v) = ∫ f_spec(l, v) cos θ_l dω_l for a_s = 1, F0 = 1, n_s = z, α = 0, by a deterministic
// midpoint grid in Ward's half-vector sampling domain (an exact change of variables):
// u → h has density p_h = exp(−tan²θ_h k(φ)) / (π σx σy cos³θ_h), k = cos²φ/σx² + sin²φ/σy²,
// and l = reflect(v, h) has p_l = p_h / (4 v·h).
double DirectionalAlbedo(double sigma_x, double sigma_y, double theta_v, double phi_v, int n) {
  WardParams<double> params;
  params.a_s = {1, 1, 1};
  params.sigma_x = sigma_x;
  params.sigma_y = sigma_y;
  const WardLobe<double> lobe(params);
  const Eigen::Vector3d v = DirectionFromSpherical(theta_v, phi_v);
  double sum = 0;
  for (int j = 0; j < n; ++j) {
    const double psi = 2 * kPi * (j + 0.5) / n;
    // φ_h = atan((σy/σx) tan ψ), kept in ψ's quadrant.
    const double phi = std::atan2(sigma_y * std::sin(psi), sigma_x * std::cos(psi));
    const double k = std::pow(std::cos(phi) / sigma_x, 2) + std::pow(std::sin(phi) / sigma_y, 2);
    for (int i = 0; i < n; ++i) {
      const double u1 = (i + 0.5) / n;
      const double tan2 = -std::log(u1) / k;
      const double cos_h = 1 / std::sqrt(1 + tan2);
      const Eigen::Vector3d h = DirectionFromSpherical(std::acos(cos_h), phi);
      const double v_dot_h = v.dot(h);
      if (v_dot_h <= 0) continue;
      const Eigen::Vector3d l = 2 * v_dot_h * h - v;
      if (l.z() <= 0) continue;
      const double p_h = std::exp(-tan2 * k) / (kPi * sigma_x * sigma_y * std::pow(cos_h, 3));
      const double p_l = p_h / (4 * v_dot_h);
      sum += lobe.Evaluate(l, v).x() * l.z() / p_l;
    }
  }
  return sum / (static_cast<double>(n) * n);
}

TEST(WardGd10Test, DirectionalAlbedoTableAndBoundedEnergy) {
  const Json& table = Reference()["albedo"];
  ASSERT_EQ(table.size(), 60u);
  for (const Json& row : table) {
    const double sx = row["sigma_x"].get<double>();
    const double sy = row["sigma_y"].get<double>();
    const double theta = DegToRad(row["theta_v_deg"].get<double>());
    const double phi = DegToRad(row["phi_v_deg"].get<double>());
    const double albedo = DirectionalAlbedo(sx, sy, theta, phi, 600);
    EXPECT_NEAR(albedo, row["albedo_gd10"].get<double>(), 2e-3)
        << "σ = (" << sx << ", " << sy << "), θ_v = " << row["theta_v_deg"] << ", φ_v = " << row["phi_v_deg"];
    EXPECT_LE(albedo, 1.0);
  }
}

// ---- Derivatives through ceres::Jet against central finite differences ----

using Jet13 = ceres::Jet<double, kNumWardParams>;

template <typename T>
WardParams<T> Unpack(const T* x) {
  WardParams<T> p;
  p.n_s = {x[0], x[1], x[2]};
  p.a_d = {x[3], x[4], x[5]};
  p.a_s = {x[6], x[7], x[8]};
  p.sigma_x = x[9];
  p.sigma_y = x[10];
  p.alpha = x[11];
  p.f0 = x[12];
  return p;
}

TEST(WardGd10Test, JetDerivativesMatchFiniteDifferences) {
  std::mt19937 rng(11);
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const WardParams<double> p = RandomParams(rng);
    const Eigen::Vector3d l = RandomUpperDirection(rng);
    const Eigen::Vector3d v = RandomUpperDirection(rng);
    if (EvaluateWardCos(p, l, v).maxCoeff() <= 0) continue;
    const double x[kNumWardParams] = {p.n_s.x(), p.n_s.y(), p.n_s.z(), p.a_d.x(), p.a_d.y(), p.a_d.z(), p.a_s.x(),
                                      p.a_s.y(), p.a_s.z(), p.sigma_x, p.sigma_y, p.alpha,   p.f0};
    Jet13 jets[kNumWardParams];
    for (int i = 0; i < kNumWardParams; ++i) jets[i] = Jet13(x[i], i);
    const Vec3<Jet13> l_jet = l.cast<Jet13>();
    const Vec3<Jet13> v_jet = v.cast<Jet13>();
    const Vec3<Jet13> f = EvaluateWardCos(Unpack(jets), l_jet, v_jet);
    for (int i = 0; i < kNumWardParams; ++i) {
      double plus[kNumWardParams], minus[kNumWardParams];
      std::copy(x, x + kNumWardParams, plus);
      std::copy(x, x + kNumWardParams, minus);
      const double step = 1e-6 * std::max(1.0, std::abs(x[i]));
      plus[i] += step;
      minus[i] -= step;
      const Eigen::Vector3d fd = (EvaluateWardCos(Unpack(plus), l, v) - EvaluateWardCos(Unpack(minus), l, v)) / (2 * step);
      for (int k = 0; k < 3; ++k) {
        ASSERT_NEAR(f[k].v[i], fd[k], 1e-5 * std::max(1.0, std::abs(fd[k])))
            << "trial " << trial << " d f[" << k << "] / d x[" << i << "]";
      }
    }
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST(WardGd10Test, CheckParamsNamesEveryProblem) {
  WardParams<double> p;
  EXPECT_TRUE(CheckWardParams(p).empty());
  p.a_d = {0.5, -0.1, 0.2};
  p.sigma_y = 2.0;
  p.f0 = 1.5;
  p.n_s = {0, 0, 2};
  const std::vector<std::string> problems = CheckWardParams(p);
  ASSERT_EQ(problems.size(), 4u);
  EXPECT_NE(problems[0].find("a_d.G"), std::string::npos) << problems[0];
}

// (σy, σx, α + π/2) is the lobe (σx, σy, α): written with σx ≥ σy, it evaluates the same.
TEST(WardGd10Test, WithSigmaXLargerIsTheSameLobe) {
  WardParams<double> p;
  p.a_s = Vec3<double>(0.3, 0.3, 0.3);
  p.sigma_x = 0.05, p.sigma_y = 0.2, p.alpha = 0.3;
  const WardParams<double> q = WithSigmaXLarger(p);
  EXPECT_EQ(q.sigma_x, 0.2);
  EXPECT_EQ(q.sigma_y, 0.05);
  EXPECT_DOUBLE_EQ(q.alpha, 0.3 + kPi / 2);
  const Vec3<double> l = Vec3<double>(0.3, -0.2, 1).normalized(), v = Vec3<double>(-0.25, 0.3, 1).normalized();
  EXPECT_NEAR(EvaluateWard(p, l, v).x(), EvaluateWard(q, l, v).x(), 1e-9 * EvaluateWard(p, l, v).x());
  EXPECT_EQ(WithSigmaXLarger(q).alpha, q.alpha);  // already so: unchanged
}

}  // namespace
}  // namespace loom::fitting
