// svbrdf.exr written and read back: the maps, their pixel size, and files that are not maps.
#include "fitting/report/export.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <limits>

#include "core/exr_io.h"
#include "fitting/io/axf_export.h"
#include "fitting/io/svbrdf_file.h"
#include "fitting/model/svbrdf_maps.h"

namespace loom::fitting {
namespace {

namespace fs = std::filesystem;

TEST(ExportTest, SvbrdfMapsReadBackWithTheirPixelSizeAndNanMapsAndOtherFilesAreRefused) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("export_test_" + std::to_string(::getpid()));
  Image maps = MakeSvbrdfImage(6, 4, false);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 6; ++x) SetParams(maps, x, y, WardParams<double>{});
  }
  WardParams<double> params;
  params.a_d = {0.2, 0.3, 0.4};
  params.sigma_x = 0.25;
  SetParams(maps, 5, 3, params);
  ASSERT_TRUE(WriteSvbrdf(dir, maps, {"cnn+refine", "stack.exr", "tac7-mini", 0.2}).ok());
  const Result<SvbrdfFile> read = ReadSvbrdf(dir / "svbrdf.exr");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->pixel_mm, 0.2);
  EXPECT_EQ(read->maps.width(), 6);
  EXPECT_NEAR(GetParams(read->maps, 5, 3).a_d.y(), 0.3, 1e-6);
  EXPECT_NEAR(GetParams(read->maps, 5, 3).sigma_x, 0.25, 1e-6);

  // Maps with a parameter that is not a number are refused, not written.
  Image broken = maps;
  broken.at(9, 2, 4) = std::numeric_limits<float>::quiet_NaN();  // sigma_x
  const Status refused = WriteSvbrdf(dir / "broken", broken, {"cnn", "stack.exr", "tac7-mini", 0.2});
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.ToString().find("sigma_x at pixel (4, 2) is not a finite number"), std::string::npos) << refused.ToString();
  EXPECT_FALSE(std::filesystem::exists(dir / "broken" / "svbrdf.exr"));

  // Values no material has are refused where maps are read, naming channel and pixel; a pixel NaN
  // in every parameter (one a fit skipped) is not one of them.
  Image skipped = maps;
  for (int c = 0; c < kNumWardParams; ++c) skipped.at(c, 1, 1) = std::numeric_limits<float>::quiet_NaN();
  ASSERT_TRUE(WriteExr(dir / "skipped.exr", skipped).ok());
  EXPECT_TRUE(ReadSvbrdf(dir / "skipped.exr").ok());
  const auto refused_on_read = [&](int channel, float value) {
    Image bad = maps;
    bad.at(channel, 2, 4) = value;
    EXPECT_TRUE(WriteExr(dir / "bad.exr", bad).ok());
    const Result<SvbrdfFile> read_bad = ReadSvbrdf(dir / "bad.exr");
    return read_bad.ok() ? std::string("read") : read_bad.status().ToString();
  };
  EXPECT_NE(refused_on_read(12, std::numeric_limits<float>::quiet_NaN()).find("F0 at pixel (4, 2) is nan"), std::string::npos);
  EXPECT_NE(refused_on_read(12, 2).find("F0 at pixel (4, 2) = 2"), std::string::npos);
  EXPECT_NE(refused_on_read(9, 0).find("sigma at pixel (4, 2) is not > 0"), std::string::npos);
  EXPECT_NE(refused_on_read(9, -1).find("bad.exr"), std::string::npos);
  EXPECT_NE(refused_on_read(4, -0.5f).find("an albedo at pixel (4, 2) is negative"), std::string::npos);
  EXPECT_NE(refused_on_read(11, std::numeric_limits<float>::infinity()).find("alpha at pixel (4, 2)"), std::string::npos);
  Image no_normal = maps;
  for (int c = 0; c < 3; ++c) no_normal.at(c, 2, 4) = 0;
  ASSERT_TRUE(WriteExr(dir / "no-normal.exr", no_normal).ok());
  const Result<SvbrdfFile> read_no_normal = ReadSvbrdf(dir / "no-normal.exr");
  ASSERT_FALSE(read_no_normal.ok());
  EXPECT_NE(read_no_normal.status().ToString().find("n_s at pixel (4, 2) has length 0"), std::string::npos)
      << read_no_normal.status().ToString();

  ASSERT_TRUE(WriteExr(dir / "grey.exr", Image(2, 2, {"Y"})).ok());
  const Result<SvbrdfFile> grey = ReadSvbrdf(dir / "grey.exr");
  ASSERT_FALSE(grey.ok());
  EXPECT_NE(grey.status().ToString().find("grey.exr"), std::string::npos) << grey.status().ToString();
  EXPECT_FALSE(ReadSvbrdf(dir / "missing.exr").ok());

  // An AxF file's SVBRDF is maps too, with the pixel size its WidthMM gives.
  ASSERT_TRUE(WriteAxf(maps, 0.2, dir / "material.axf").ok());
  const Result<SvbrdfFile> axf = ReadSvbrdf(dir / "material.axf");
  ASSERT_TRUE(axf.ok()) << axf.status().ToString();
  EXPECT_NEAR(axf->pixel_mm, 0.2, 1e-6);
  EXPECT_NEAR(GetParams(axf->maps, 5, 3).sigma_x, 0.25, 1e-6);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace loom::fitting
