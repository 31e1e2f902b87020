// The glTF export: the files a renderer loads, and the per-pixel mapping gltf_export.h states,
// read back from the PNGs it wrote.
#include "fitting/report/gltf_export.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "fitting/model/svbrdf_maps.h"
#include "fitting/report/export.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

WardParams<double> Pixel(const Eigen::Vector3d& n_s, double sigma_x, double sigma_y) {
  WardParams<double> p;
  p.n_s = n_s;
  p.a_d = {0.5, 0.25, 0.1};
  p.a_s = {0.2, 0.1, 0.05};
  p.f0 = 0.5;
  p.sigma_x = sigma_x;
  p.sigma_y = sigma_y;
  p.alpha = 0.3;
  return p;
}

double SrgbToLinear(uint8_t v) {
  const double c = v / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// Channel `rgb` (0 R, 1 G, 2 B) of a PNG pixel, in [0, 1].
double Texel(const fs::path& png, int x, int rgb) {
  const cv::Mat image = cv::imread(png.string(), cv::IMREAD_COLOR);
  EXPECT_FALSE(image.empty()) << png;
  return image.at<cv::Vec3b>(0, x)[2 - rgb] / 255.0;
}

class GltfExportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("gltf_export_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(GltfExportTest, WritesAQuadWithTheTexturesAndExtensions) {
  Image maps = MakeSvbrdfImage(2, 1, false);
  SetParams(maps, 0, 0, Pixel({0, 0, 1}, 0.2, 0.05));
  SetParams(maps, 1, 0, Pixel({std::sin(0.2), 0, std::cos(0.2)}, 0.05, 0.2));
  ASSERT_TRUE(WriteGltf(maps, 0.5, dir_, GltfAnisotropy::kOn).ok());
  std::ifstream file(dir_ / "material.gltf");
  const nlohmann::json gltf = nlohmann::json::parse(file);
  EXPECT_EQ(gltf["asset"]["version"], "2.0");
  EXPECT_EQ(gltf["extensionsUsed"], nlohmann::json({"KHR_materials_anisotropy", "KHR_materials_specular"}));
  EXPECT_EQ(gltf["buffers"][0]["byteLength"].get<size_t>(), fs::file_size(dir_ / "material.bin"));
  // 2 px of 0.5 mm: a quad 1 mm by 0.5 mm, in metres.
  EXPECT_EQ(gltf["accessors"][0]["max"], nlohmann::json({0.0005, 0.0, 0.00025}));
  for (const auto& image : gltf["images"]) EXPECT_TRUE(fs::exists(dir_ / image["uri"].get<std::string>())) << image;
  // F0 colour a_s · F0, at most 0.1 here: 2.5 × the dielectric 0.04, the texture at 1 there.
  const auto& specular = gltf["materials"][0]["extensions"]["KHR_materials_specular"];
  EXPECT_NEAR(specular["specularColorFactor"][0].get<double>(), 2.5, 1e-6);  // the maps are float
  EXPECT_NEAR(SrgbToLinear(static_cast<uint8_t>(std::lround(255 * Texel(dir_ / "specular_color.png", 0, 0)))), 1.0, 1e-9);
  EXPECT_NEAR(SrgbToLinear(static_cast<uint8_t>(std::lround(255 * Texel(dir_ / "specular_color.png", 0, 2)))), 0.25, 0.01);
  EXPECT_NEAR(SrgbToLinear(static_cast<uint8_t>(std::lround(255 * Texel(dir_ / "base_color.png", 0, 1)))), 0.25, 0.01);

  // Roughness from the smaller σ: √(√2 · 0.05); anisotropy strength from both.
  const GltfRoughness r = GltfRoughnessOf(0.2, 0.05);
  EXPECT_NEAR(Texel(dir_ / "metallic_roughness.png", 0, 1), std::sqrt(std::sqrt(2.0) * 0.05), 1.0 / 255);
  EXPECT_NEAR(Texel(dir_ / "metallic_roughness.png", 0, 2), 0.0, 1e-9);  // metallic
  EXPECT_NEAR(Texel(dir_ / "anisotropy.png", 0, 2), r.anisotropy_strength, 1.0 / 255);

  // Pixel 0's lobe is long along t = (cos α, sin α) in the sample; tangent space has B = −y.
  const auto direction = [&](int x) {
    return Eigen::Vector2d(2 * Texel(dir_ / "anisotropy.png", x, 0) - 1, 2 * Texel(dir_ / "anisotropy.png", x, 1) - 1);
  };
  EXPECT_NEAR(std::abs(direction(0).dot(Eigen::Vector2d(std::cos(0.3), -std::sin(0.3)))), 1.0, 0.01);
  // Pixel 1's is long along b = n_s × t: σy is the larger.
  const AnisotropyFrame<double> frame = MakeAnisotropyFrame(Eigen::Vector3d(std::sin(0.2), 0, std::cos(0.2)), 0.3);
  const Eigen::Vector2d b = Eigen::Vector2d(frame.b.x(), -frame.b.y()).normalized();
  EXPECT_NEAR(std::abs(direction(1).dot(b)), 1.0, 0.01);
  // Pixel 1's shading normal tilts towards +x: red above 0.5, green (B = −y) and blue as they are.
  EXPECT_NEAR(Texel(dir_ / "normal.png", 1, 0), (std::sin(0.2) + 1) / 2, 1.0 / 255);
  EXPECT_NEAR(Texel(dir_ / "normal.png", 1, 1), 0.5, 1.0 / 255);
  EXPECT_NEAR(Texel(dir_ / "normal.png", 1, 2), (std::cos(0.2) + 1) / 2, 1.0 / 255);
}

TEST_F(GltfExportTest, TheAnisotropicRoughnessIsGltfsMixOfTheTwo) {
  for (const auto& [sx, sy] : {std::pair{0.3, 0.1}, {0.1, 0.3}, {0.02, 0.5}, {0.2, 0.2}}) {
    const GltfRoughness r = GltfRoughnessOf(sx, sy);
    const double alpha_b = r.roughness * r.roughness;
    const double alpha_t = alpha_b + (1 - alpha_b) * r.anisotropy_strength * r.anisotropy_strength;  // glTF's mix
    EXPECT_NEAR(alpha_b, std::sqrt(2.0) * std::min(sx, sy), 1e-9);
    EXPECT_NEAR(alpha_t, std::sqrt(2.0) * std::max(sx, sy), 1e-9);
    EXPECT_EQ(r.along_b, sy > sx);
  }
}

// Renderers keep KHR_materials_anisotropy's tangents in the quad's plane: shading normals that
// tilt further than the lobe is wide get an isotropic export, with α = √(α_t α_b).
TEST_F(GltfExportTest, ShadingNormalsTiltedWiderThanTheLobeGiveAnIsotropicExport) {
  const auto write = [&](double tilt, const std::string& name) {
    Image maps = MakeSvbrdfImage(1, 1, false);
    SetParams(maps, 0, 0, Pixel({std::sin(tilt), 0, std::cos(tilt)}, 0.2, 0.05));
    EXPECT_TRUE(WriteGltf(maps, 0.5, dir_ / name).ok());
    std::ifstream file(dir_ / name / "material.gltf");
    return nlohmann::json::parse(file);
  };
  const nlohmann::json slight = write(0.04, "slight");  // tan(tilt) / σ_min = 0.8
  EXPECT_EQ(slight["extensionsUsed"], nlohmann::json({"KHR_materials_anisotropy", "KHR_materials_specular"}));
  const nlohmann::json steep = write(0.3, "steep");  // 6.2
  EXPECT_EQ(steep["extensionsUsed"], nlohmann::json({"KHR_materials_specular"}));
  EXPECT_EQ(steep["images"].size(), 4u);
  EXPECT_NE(steep["materials"][0]["extras"]["loom_anisotropy"].get<std::string>().find("isotropic"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "steep" / "anisotropy.png"));
  EXPECT_NEAR(Texel(dir_ / "steep" / "metallic_roughness.png", 0, 1), std::sqrt(std::sqrt(2 * 0.2 * 0.05)), 1.0 / 255);
}

TEST_F(GltfExportTest, AHeightmapTiltsTheNormals) {
  Image maps = MakeSvbrdfImage(3, 1, true);
  const int height = *maps.FindChannel(kHeightChannel);
  for (int x = 0; x < 3; ++x) {
    SetParams(maps, x, 0, Pixel({0, 0, 1}, 0.1, 0.1));
    maps.at(height, 0, x) = static_cast<float>(0.1 * 0.2 * x);  // 0.1 mm rise per mm along x
  }
  ASSERT_TRUE(WriteGltf(maps, 0.2, dir_).ok());
  const Eigen::Vector3d n = Eigen::Vector3d(-0.1, 0, 1).normalized();
  EXPECT_NEAR(Texel(dir_ / "normal.png", 1, 0), (n.x() + 1) / 2, 1.0 / 255);
  EXPECT_NEAR(Texel(dir_ / "normal.png", 1, 2), (n.z() + 1) / 2, 1.0 / 255);
}

TEST_F(GltfExportTest, TexturesArePaddedToPowersOfTwoTexelForTexel) {
  Image maps = MakeSvbrdfImage(3, 5, false);
  for (int y = 0; y < 5; ++y) {
    for (int x = 0; x < 3; ++x) {
      WardParams<double> p = Pixel({0, 0, 1}, 0.1, 0.1);
      p.a_d = Eigen::Vector3d::Constant(0.1 + 0.1 * x + 0.02 * y);
      SetParams(maps, x, y, p);
    }
  }
  ASSERT_TRUE(WriteGltf(maps, 0.5, dir_).ok());
  const cv::Mat base = cv::imread((dir_ / "base_color.png").string(), cv::IMREAD_COLOR);
  ASSERT_EQ(base.cols, 4);
  ASSERT_EQ(base.rows, 8);
  EXPECT_EQ(base.at<cv::Vec3b>(4, 2)[1], ToSrgb8(0.1 + 0.2 + 0.08));  // a texel of the maps, as it was
  EXPECT_EQ(base.at<cv::Vec3b>(4, 3), base.at<cv::Vec3b>(4, 2));      // the padding repeats the edge
  EXPECT_EQ(base.at<cv::Vec3b>(7, 1), base.at<cv::Vec3b>(4, 1));
  // The quad's texture coordinates (the 4th block of material.bin) span the maps' 3 × 5 texels.
  std::ifstream bin(dir_ / "material.bin", std::ios::binary);
  float uvs[8];
  bin.seekg(48 + 48 + 64);
  bin.read(reinterpret_cast<char*>(uvs), sizeof uvs);
  EXPECT_EQ(std::vector<float>(uvs, uvs + 8), (std::vector<float>{0, 0, 0.75f, 0, 0.75f, 0.625f, 0, 0.625f}));
}

TEST_F(GltfExportTest, MapsWithoutAPixelSizeAreRefused) {
  const Status written = WriteGltf(MakeSvbrdfImage(2, 2, false), 0, dir_).status();
  EXPECT_NE(written.ToString().find("loom.pixel_mm"), std::string::npos) << written.ToString();
  EXPECT_FALSE(fs::exists(dir_ / "material.gltf"));
}

}  // namespace
}  // namespace loom::fitting
