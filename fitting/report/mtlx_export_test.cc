// The MaterialX export's per-pixel mapping (mtlx_export.h), read back from the files it wrote.
// That the MaterialX library accepts them is web/tests/mtlx_validation_test.sh's.
#include "fitting/report/mtlx_export.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

// Standard Surface's own roughness and anisotropy to α (MaterialX's mx_roughness_anisotropy).
std::pair<double, double> StandardSurfaceAlphas(const StandardSurfaceRoughness& r) {
  const double aspect = std::sqrt(1 - std::min(r.anisotropy, 0.98));
  return {std::min(r.roughness * r.roughness / aspect, 1.0), r.roughness * r.roughness * aspect};
}

TEST(MaterialXExportTest, StandardSurfacesRoughnessGivesTheLobesGgxAlphas) {
  const auto [wider, narrower] = StandardSurfaceAlphas(StandardSurfaceRoughnessOf(0.1, 0.3));
  EXPECT_NEAR(wider, std::sqrt(2.0) * 0.3, 1e-9);
  EXPECT_NEAR(narrower, std::sqrt(2.0) * 0.1, 1e-9);
  const StandardSurfaceRoughness isotropic = StandardSurfaceRoughnessOf(0.2, 0.2);
  EXPECT_EQ(isotropic.anisotropy, 0);
  EXPECT_NEAR(isotropic.roughness * isotropic.roughness, std::sqrt(2.0) * 0.2, 1e-9);
}

TEST(MaterialXExportTest, WritesTheDocumentAndTexturesWithTheIorOfTheLargestSpecularReflectance) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("mtlx_export_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  Image maps = MakeSvbrdfImage(3, 2, false);
  WardParams<double> p;
  p.n_s = {0, 0, 1};
  p.a_d = {0.5, 0.25, 0.1};
  p.a_s = {0.2, 0.1, 0.05};
  p.f0 = 0.5;
  p.sigma_x = 0.1;
  p.sigma_y = 0.3;  // the wider axis along b: a quarter turn from the tangent, α 0 aside
  p.alpha = 0;
  for (int y = 0; y < 2; ++y) {
    for (int x = 0; x < 3; ++x) SetParams(maps, x, y, p);
  }
  p.sigma_y = 0.05;  // the wider axis along t, turned by α from the image's columns towards its rows
  p.alpha = 0.3;
  SetParams(maps, 1, 0, p);
  ASSERT_TRUE(WriteMaterialX(maps, 0.5, dir).ok());
  std::ifstream in(dir / "material.mtlx");
  std::stringstream text;
  text << in.rdbuf();
  std::smatch ior;
  const std::string document = text.str();
  ASSERT_TRUE(std::regex_search(document, ior, std::regex("specular_IOR\" type=\"float\" value=\"([0-9.]+)\"")));
  const double n = std::stod(ior[1]);
  EXPECT_NEAR(std::pow((n - 1) / (n + 1), 2), 0.2 * 0.5, 1e-4);  // max a_s · F0
  EXPECT_NE(document.find("A 1.5 x 1 mm sample, 3 x 2 texels"), std::string::npos) << document;
  const cv::Mat rotation = cv::imread((dir / "rotation.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(rotation.cols, 3);
  EXPECT_NEAR(rotation.at<uint8_t>(0, 0) / 255.0, 0.25, 1.0 / 255);
  // Clockwise about the normal, as MaterialX's rotate3d turns the tangent in its shaders
  // (web/render-mtlx.mjs renders them): 0.3 rad towards down the image is half a turn less 0.3.
  EXPECT_NEAR(rotation.at<uint8_t>(0, 1) / 255.0, 0.5 - 0.3 / (2 * M_PI), 1.0 / 255);
  const cv::Mat specular = cv::imread((dir / "specular_color.png").string(), cv::IMREAD_COLOR);
  EXPECT_EQ(specular.at<cv::Vec3b>(1, 2)[2], 255) << "the largest tint is white: the IOR carries the scale";
  for (const char* texture : {"base_color", "roughness", "anisotropy", "normal"}) {
    EXPECT_TRUE(fs::exists(dir / (std::string(texture) + ".png"))) << texture;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loom::fitting
