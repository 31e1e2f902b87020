#include "sim/fabric.h"

#include <gtest/gtest.h>

#include <set>

#include "fitting/model/svbrdf_maps.h"
#include "sim/reflectance.h"

namespace loom::sim {
namespace {

using fitting::GetParams;
using fitting::WardParams;

FabricOptions Small(int size = 48) {
  FabricOptions options;
  options.width_px = options.height_px = size;
  options.supersampling = 2;
  return options;
}

TEST(FabricTest, SameSeedSameMapsOtherSeedOtherMaps) {
  const Material a = GenerateFabric(42, Small());
  const Material b = GenerateFabric(42, Small());
  const Material c = GenerateFabric(43, Small());
  ASSERT_EQ(a.maps.num_channels(), 14);
  const size_t floats = a.maps.pixel_count() * a.maps.num_channels();
  EXPECT_TRUE(std::equal(a.maps.data(), a.maps.data() + floats, b.maps.data()));
  EXPECT_FALSE(std::equal(a.maps.data(), a.maps.data() + floats, c.maps.data()));
}

TEST(FabricTest, EveryPixelIsAValidModelParameterSet) {
  for (uint64_t seed = 0; seed < 20; ++seed) {
    const Material m = GenerateFabric(seed, Small());
    for (int y = 0; y < m.height(); ++y) {
      for (int x = 0; x < m.width(); ++x) {
        const WardParams<double> p = GetParams(m.maps, x, y);
        const std::vector<std::string> problems = fitting::CheckWardParams(p);
        ASSERT_TRUE(problems.empty()) << "seed " << seed << " pixel " << x << "," << y << ": " << problems[0];
        ASSERT_LE((p.a_d + p.a_s).maxCoeff(), 1.0) << "energy at seed " << seed;
      }
    }
  }
}

TEST(FabricTest, ThreadDirectionDrivesTheAnisotropyAngle) {
  FabricDescription f = RandomFabric(5);
  f.weave = Weave::kPlain;
  f.rotation_rad = 0;
  f.twist_rad = 0;
  const Material m = MakeFabric(f, Small(64));
  int warp = 0, weft = 0;
  for (int y = 0; y < m.height(); ++y) {
    for (int x = 0; x < m.width(); ++x) {
      const double alpha = GetParams(m.maps, x, y).alpha;
      ASSERT_TRUE(std::abs(alpha - kPi / 2) < 1e-6 || std::abs(alpha) < 1e-6) << alpha;
      (std::abs(alpha) < 1e-6 ? weft : warp)++;
    }
  }
  // A plain weave shows about as much warp as weft.
  EXPECT_NEAR(static_cast<double>(warp) / (warp + weft), 0.5, 0.1);
}

TEST(FabricTest, WeavesShowTheirWarpShare) {
  // Fraction of the surface where the warp lies on top: plain 1/2, twill 2/1 2/3, satin 4/5.
  const std::pair<Weave, double> weaves[] = {{Weave::kPlain, 0.5}, {Weave::kTwill21, 2.0 / 3}, {Weave::kSatin5, 0.8}};
  for (const auto& [weave, share] : weaves) {
    FabricDescription f = RandomFabric(9);
    f.weave = weave;
    f.rotation_rad = 0;
    f.twist_rad = 0;
    f.pitch_mm = 0.5;
    const Material m = MakeFabric(f, Small(120));
    int warp = 0;
    int top = 0;
    const int height_channel = *m.maps.ChannelIndex("height");
    for (int y = 0; y < m.height(); ++y) {
      for (int x = 0; x < m.width(); ++x) {
        if (m.maps.at(height_channel, y, x) < 0.5 * f.relief_mm * 0.55) continue;  // not a top thread
        ++top;
        warp += GetParams(m.maps, x, y).alpha > 1.0;
      }
    }
    EXPECT_NEAR(static_cast<double>(warp) / top, share, 0.08) << WeaveName(weave);
  }
}

TEST(FabricTest, GeneratedMaterialsCoverTheModelsRanges) {
  double sx_min = 1, sx_max = 0, sy_max = 0, f0_min = 1, f0_max = 0, tilt_max = 0, aniso_max = 1;
  std::set<std::string> weaves;
  std::set<int> alpha_bins;
  Eigen::Vector3d ad_max = Eigen::Vector3d::Zero();
  for (uint64_t seed = 100; seed < 260; ++seed) {
    const Material m = GenerateFabric(seed, Small(24));
    weaves.insert(std::get<std::string>(m.provenance.at("loom.weave")));
    for (int y = 0; y < m.height(); y += 3) {
      for (int x = 0; x < m.width(); x += 3) {
        const WardParams<double> p = GetParams(m.maps, x, y);
        sx_min = std::min(sx_min, p.sigma_x);
        sx_max = std::max(sx_max, p.sigma_x);
        sy_max = std::max(sy_max, p.sigma_y);
        aniso_max = std::max(aniso_max, p.sigma_y / p.sigma_x);
        f0_min = std::min(f0_min, p.f0);
        f0_max = std::max(f0_max, p.f0);
        tilt_max = std::max(tilt_max, std::acos(p.n_s.z()));
        alpha_bins.insert(static_cast<int>(std::floor((p.alpha + kPi / 2) / (kPi / 4))));
        ad_max = ad_max.cwiseMax(p.a_d);
      }
    }
  }
  EXPECT_EQ(weaves.size(), 4u);
  EXPECT_LT(sx_min, 0.025);
  EXPECT_GT(sx_max, 0.25);
  EXPECT_GT(sy_max, 0.7);
  EXPECT_GT(aniso_max, 5.0);  // σx ≠ σy, strongly
  EXPECT_LT(f0_min, 0.05);
  EXPECT_GT(f0_max, 0.95);
  EXPECT_GT(RadToDeg(tilt_max), 15.0);  // thread relief tilts the shading normals
  EXPECT_EQ(alpha_bins.size(), 4u);     // every quarter of (−π/2, π/2]
  EXPECT_GT(ad_max.minCoeff(), 0.5);
}

TEST(FabricTest, AnOutOfModelFabricIsItsSeedsFabricWithWhatGd10CannotRepresent) {
  int tinted = 0, coated = 0, masked = 0, meso = 0;
  for (uint64_t seed = 0; seed < 12; ++seed) {
    const Material plain = GenerateFabric(seed, Small(16));
    const Material beyond = GenerateOutOfModelFabric(seed, Small(16));
    const FabricBeyond choices = RandomFabricBeyond(seed);
    const Result<std::optional<BeyondLayout>> layout = FindBeyondChannels(beyond.maps);
    ASSERT_TRUE(layout.ok() && layout->has_value()) << "seed " << seed;
    for (int y = 0; y < 16; y += 5) {
      for (int x = 0; x < 16; x += 5) {
        const WardParams<double> a = GetParams(plain.maps, x, y), b = GetParams(beyond.maps, x, y);
        // The geometry and the lobe's shape are the fabric's; the albedos are tinted and scaled.
        EXPECT_EQ(a.n_s, b.n_s);
        EXPECT_EQ(a.sigma_x, b.sigma_x);
        EXPECT_EQ(a.alpha, b.alpha);
        EXPECT_NEAR((a.a_s.cwiseProduct(choices.specular_tint) - b.a_s).norm(), 0, 1e-6);
        EXPECT_NEAR((a.a_d * (1 - choices.coat) - b.a_d).norm(), 0, 1e-6);
        EXPECT_LE((b.a_d + b.a_s).maxCoeff() + choices.coat, 1.0 + 1e-6) << "energy at seed " << seed;
        const BeyondGd10 pixel = GetBeyond(beyond.maps, **layout, x, y);
        EXPECT_NEAR(pixel.coat.x(), choices.coat, 1e-6);
        EXPECT_NEAR(pixel.meso_deg, choices.meso_deg, 1e-5);
      }
    }
    tinted += choices.specular_tint.minCoeff() < 0.95;
    coated += choices.coat > 0;
    masked += choices.fibre_masking > 0;
    meso += choices.meso_deg > 0;
  }
  // Each effect on for some seeds and off for others.
  for (int count : {tinted, coated, masked, meso}) {
    EXPECT_GT(count, 1);
    EXPECT_LT(count, 12);
  }
}

TEST(FabricTest, WriteReadRoundTrip) {
  const Material m = GenerateFabric(7, Small(32));
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) / "fabric7.exr";
  ASSERT_TRUE(WriteMaterial(m, path).ok());
  const Result<Material> read = ReadMaterial(path);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->pixel_mm, m.pixel_mm);
  EXPECT_EQ(read->name, m.name);
  EXPECT_EQ(read->maps.channel_names(), m.maps.channel_names());
  EXPECT_EQ(read->maps.at(11, 5, 9), m.maps.at(11, 5, 9));
}

}  // namespace
}  // namespace loom::sim
