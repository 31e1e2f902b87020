#include "fitting/model/label.h"
#include "core/testing/build_tree.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

namespace loom::fitting {
namespace {

TEST(LabelTest, SigmaEncodingMapsUnitIntervalOntoItself) {
  EXPECT_NEAR(EncodeSigma(0.0), 0.0, 1e-15);
  EXPECT_NEAR(EncodeSigma(1.0), 1.0, 1e-15);
  EXPECT_NEAR(DecodeSigma(EncodeSigma(0.037)), 0.037, 1e-15);
  EXPECT_GT(EncodeSigma(0.05), 0.35);  // small σ are spread out
}

TEST(LabelTest, MatchesReferenceLabels) {
  std::ifstream in(loom::testing::SourceDir() + "/fitting/model/testdata/ward_gd10_reference.json");
  ASSERT_TRUE(in);
  const nlohmann::json reference = nlohmann::json::parse(in);
  for (const nlohmann::json& c : reference["cases"]) {
    const nlohmann::json& p = c["params"];
    WardParams<double> params;
    const auto vec = [](const nlohmann::json& j) {
      return Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
    };
    params.a_d = vec(p["a_d"]);
    params.a_s = vec(p["a_s"]);
    params.n_s = vec(p["n_s"]);
    params.sigma_x = p["sigma_x"];
    params.sigma_y = p["sigma_y"];
    params.alpha = p["alpha"];
    params.f0 = p["F0"];
    const Label label = EncodeLabel(params);
    for (int i = 0; i < kLabelSize; ++i) {
      ASSERT_NEAR(label[i], c["label14"][i].get<double>(), 1e-12) << "case " << c["id"] << " index " << i;
    }
  }
}

TEST(LabelTest, EncodeDecodeRoundTrip) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < 1000; ++i) {
    WardParams<double> p;
    p.n_s = DirectionFromSpherical(1.4 * unit(rng), 2 * kPi * unit(rng));
    p.a_d = {unit(rng), unit(rng), unit(rng)};
    p.a_s = {unit(rng), unit(rng), unit(rng)};
    p.sigma_x = kMinSigma + unit(rng);
    p.sigma_y = kMinSigma + unit(rng);
    p.alpha = kPi * (unit(rng) - 0.5);
    p.f0 = unit(rng);
    const WardParams<double> q = DecodeLabel(EncodeLabel(p));
    ASSERT_TRUE(q.n_s.isApprox(p.n_s, 1e-12));
    ASSERT_TRUE(q.a_d.isApprox(p.a_d, 1e-12));
    ASSERT_TRUE(q.a_s.isApprox(p.a_s, 1e-12));
    ASSERT_NEAR(q.sigma_x, p.sigma_x, 1e-12);
    ASSERT_NEAR(q.sigma_y, p.sigma_y, 1e-12);
    ASSERT_NEAR(q.alpha, p.alpha, 1e-12);
    ASSERT_NEAR(q.f0, p.f0, 1e-15);
  }
}

TEST(LabelTest, DecodingRepairsRawNetworkOutput) {
  // What an untrained network may output: unnormalised vectors, negative values.
  const Label raw = {-0.1, 0.5, 0.2, 0.3, -2, 0.1, 0.2, 0.1, -0.5, -0.3, 0.4, 0, 3, 1.7};
  const WardParams<double> p = DecodeLabel(raw);
  EXPECT_EQ(p.a_d.x(), 0.0);
  EXPECT_EQ(p.a_s.y(), 0.0);
  EXPECT_NEAR(p.n_s.norm(), 1.0, 1e-12);
  EXPECT_GT(p.n_s.z(), 0.0);
  EXPECT_EQ(p.sigma_x, kSigmaFloor);
  EXPECT_NEAR(p.alpha, kPi / 4, 1e-12);  // (cos 2α, sin 2α) ∝ (0, 3)
  EXPECT_EQ(p.f0, 1.0);
  EXPECT_TRUE(CheckWardParams(p).size() == 1);  // only σx below kMinSigma is left to report
}

}  // namespace
}  // namespace loom::fitting
