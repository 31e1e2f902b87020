#include "core/exr_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <random>

namespace loom {
namespace {

namespace fs = std::filesystem;

class ExrIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(testing::TempDir()) /
           ("exr_io_test_" + std::string(testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static Image RandomImage(int width, int height, std::vector<std::string> names, uint32_t seed) {
    Image image(width, height, std::move(names));
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> value(-10.0f, 1000.0f);
    for (int c = 0; c < image.num_channels(); ++c) {
      for (float& v : image.channel(c)) v = value(rng);
    }
    return image;
  }

  fs::path dir_;
};

TEST_F(ExrIoTest, FloatRoundTripIsExactAndKeepsChannelOrder) {
  // Deliberately not alphabetical: EXR sorts channel names, loom keeps its own order.
  const Image image = RandomImage(37, 21, {"sigma_y", "a_d.R", "a_d.G", "a_d.B", "alpha"}, 1);
  const fs::path path = dir_ / "maps.exr";
  ASSERT_TRUE(WriteExr(path, image).ok());
  const Result<ExrImage> read = ReadExr(path);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->image.channel_names(), image.channel_names());
  ASSERT_EQ(read->image.width(), 37);
  ASSERT_EQ(read->image.height(), 21);
  for (int c = 0; c < image.num_channels(); ++c) {
    for (size_t i = 0; i < image.pixel_count(); ++i) {
      ASSERT_EQ(read->image.channel(c)[i], image.channel(c)[i]) << c << " " << i;
    }
  }
}

TEST_F(ExrIoTest, HalfStorageKeepsHalfPrecision) {
  const Image image = RandomImage(16, 8, {"Y"}, 2);
  const fs::path path = dir_ / "half.exr";
  const Status written = WriteExr(path, image, {}, {.pixel_type = ExrPixelType::kHalf});
  ASSERT_TRUE(written.ok()) << written.ToString();
  const Result<ExrImage> read = ReadExr(path);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  double max_relative = 0;
  for (size_t i = 0; i < image.pixel_count(); ++i) {
    const float a = image.channel(0)[i];
    const float b = read->image.channel(0)[i];
    if (std::abs(a) > 1e-2f) max_relative = std::max<double>(max_relative, std::abs(a - b) / std::abs(a));
  }
  EXPECT_LT(max_relative, 1.0 / 1024);  // half has an 11-bit significand
  EXPECT_GT(max_relative, 0.0);         // and it really was stored as half
  const fs::path float_path = dir_ / "float.exr";
  ASSERT_TRUE(WriteExr(float_path, image, {}, {.compression = ExrCompression::kNone}).ok());
  ASSERT_TRUE(WriteExr(path, image, {}, {.pixel_type = ExrPixelType::kHalf, .compression = ExrCompression::kNone}).ok());
  // 2 bytes per sample instead of 4, same header.
  EXPECT_EQ(fs::file_size(float_path) - fs::file_size(path), 16u * 8u * 2u);
}

TEST_F(ExrIoTest, AttributesRoundTrip) {
  Eigen::Matrix4d sample_from_cam;
  sample_from_cam << 1, 0, 0, 10, 0, 0, -1, 20, 0, 1, 0, 30, 0, 0, 0, 1;
  Eigen::Matrix3d k;
  k << 1200, 0, 320, 0, 1210, 240, 0, 0, 1;
  const ExrAttributes attributes = {{"loom.version", std::string("0.1.0")},
                                    {"pixelSize_mm", 0.2},
                                    {"observations", 934},
                                    {"exposure_us", 1250.5f},
                                    {"sample_from_cam", sample_from_cam},
                                    {"K", k},
                                    {"lightPosition_mm", Eigen::Vector3d(1.5, -2, 300)}};
  const fs::path path = dir_ / "attrs.exr";
  ASSERT_TRUE(WriteExr(path, RandomImage(4, 4, {"Y"}, 3), attributes).ok());
  const Result<ExrHeader> header = ReadExrHeader(path);
  ASSERT_TRUE(header.ok()) << header.status().ToString();
  EXPECT_EQ(header->attributes, attributes);
  EXPECT_EQ(header->width, 4);
  EXPECT_EQ(header->channel_names, std::vector<std::string>{"Y"});
}

TEST_F(ExrIoTest, ReservedAttributeNameIsRejected) {
  const Status status = WriteExr(dir_ / "x.exr", RandomImage(2, 2, {"Y"}, 4), {{"compression", std::string("none")}});
  EXPECT_EQ(status.code(), StatusCode::kInvalidArgument);
  EXPECT_FALSE(fs::exists(dir_ / "x.exr"));
}

TEST_F(ExrIoTest, StackWithAThousandChannels) {
  // The calibrated HDR stacks hold ~1000 channels per pixel (934 in the paper's layout).
  std::vector<std::string> names;
  for (int i = 0; i < 934; ++i) names.push_back("obs" + std::to_string(10000 + i).substr(1));
  const Image image = RandomImage(24, 20, names, 5);
  const fs::path path = dir_ / "stack.exr";
  ASSERT_TRUE(WriteExr(path, image, {}, {.compression = ExrCompression::kNone}).ok());
  const Result<ExrImage> read = ReadExr(path);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->image.num_channels(), 934);
  EXPECT_EQ(read->image.channel_name(933), "obs0933");
  EXPECT_EQ(read->image.at(933, 19, 23), image.at(933, 19, 23));
  EXPECT_EQ(read->image.at(0, 0, 0), image.at(0, 0, 0));

  const Result<ExrImage> subset = ReadExr(path, {.channels = {"obs0500", "obs0007"}});
  ASSERT_TRUE(subset.ok());
  EXPECT_EQ(subset->image.channel_names(), (std::vector<std::string>{"obs0500", "obs0007"}));
  EXPECT_EQ(subset->image.at(0, 5, 5), image.at(500, 5, 5));
}

TEST_F(ExrIoTest, MissingChannelInSubsetNamesChannelAndFile) {
  const fs::path path = dir_ / "y.exr";
  ASSERT_TRUE(WriteExr(path, RandomImage(2, 2, {"Y"}, 6)).ok());
  const Result<ExrImage> read = ReadExr(path, {.channels = {"Z"}});
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.status().code(), StatusCode::kNotFound);
  EXPECT_EQ(read.status().subject(), path.string());
  EXPECT_NE(read.status().message().find("'Z'"), std::string::npos);
}

TEST_F(ExrIoTest, MissingFileIsNotFound) {
  const fs::path path = dir_ / "missing.exr";
  const Result<ExrImage> read = ReadExr(path);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.status().code(), StatusCode::kNotFound);
  EXPECT_EQ(read.status().subject(), path.string());
  EXPECT_FALSE(ReadExrHeader(path).ok());
}

TEST_F(ExrIoTest, NonExrFileIsRejected) {
  const fs::path path = dir_ / "frame.exr";
  std::ofstream(path) << "P5\n4 4\n255\n0123456789abcdef";
  const Result<ExrImage> read = ReadExr(path);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(read.status().subject(), path.string());
  EXPECT_NE(read.status().message().find("not an OpenEXR file"), std::string::npos);
}

TEST_F(ExrIoTest, TruncatedFileIsDataLossAtEveryCut) {
  const fs::path good = dir_ / "good.exr";
  ASSERT_TRUE(WriteExr(good, RandomImage(64, 64, {"R", "G", "B"}, 7), {}, {.compression = ExrCompression::kNone}).ok());
  std::ifstream in(good, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Cuts inside the header, the offset table, the first scanlines and the last byte.
  for (const size_t keep : {size_t{8}, size_t{100}, size_t{400}, bytes.size() / 3, bytes.size() / 2, bytes.size() - 1}) {
    const fs::path cut = dir_ / ("cut_" + std::to_string(keep) + ".exr");
    std::ofstream(cut, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(keep));
    const Result<ExrImage> read = ReadExr(cut);
    ASSERT_FALSE(read.ok()) << "kept " << keep << " of " << bytes.size() << " bytes";
    EXPECT_EQ(read.status().subject(), cut.string());
    EXPECT_NE(read.status().code(), StatusCode::kOk);
  }
}

// A header that declares a string attribute of nearly 2 GB (a fuzzed stack did): refused as a
// corrupt header before OpenEXR's reader allocates what it declares.
TEST_F(ExrIoTest, AnAttributeSizeBeyondTheFileIsACorruptHeader) {
  const fs::path path = dir_ / "damaged.exr";
  ASSERT_TRUE(WriteExr(path, RandomImage(4, 4, {"Y"}, 3), {{"loom.note", std::string("hello")}}).ok());
  std::ifstream in(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  const std::string field = std::string("loom.note") + '\0' + "string" + '\0';
  const size_t at = bytes.find(field);
  ASSERT_NE(at, std::string::npos);
  const uint32_t huge = 0x72000000;  // little-endian int32 size, as OpenEXR stores it
  std::memcpy(bytes.data() + at + field.size(), &huge, sizeof huge);
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  for (const auto& status : {ReadExr(path).status(), ReadExrHeader(path).status()}) {
    EXPECT_EQ(status.code(), StatusCode::kDataLoss) << status.ToString();
    EXPECT_EQ(status.subject(), path.string());
    EXPECT_NE(status.message().find("corrupt EXR header"), std::string::npos) << status.ToString();
  }
}

TEST_F(ExrIoTest, WriteIsAtomicAndFailureNamesTheFile) {
  const fs::path path = dir_ / "out.exr";
  ASSERT_TRUE(WriteExr(path, RandomImage(8, 8, {"Y"}, 8)).ok());
  ASSERT_TRUE(WriteExr(path, RandomImage(8, 8, {"Y"}, 9)).ok());  // replaces
  int entries = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir_)) ++entries;
  EXPECT_EQ(entries, 1);  // no temporary left behind

  const fs::path unwritable = dir_ / "no_such_dir" / "out.exr";
  const Status status = WriteExr(unwritable, RandomImage(8, 8, {"Y"}, 10));
  EXPECT_EQ(status.code(), StatusCode::kIoError);
  EXPECT_EQ(status.subject(), unwritable.string());

  const Status empty = WriteExr(path, Image());
  EXPECT_EQ(empty.code(), StatusCode::kInvalidArgument);
  EXPECT_TRUE(ReadExr(path).ok());  // the earlier file is intact
}

TEST_F(ExrIoTest, Uint16FramesAreLossless) {
  std::vector<uint16_t> pixels(64 * 48);
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = static_cast<uint16_t>((i * 2654435761u) & 0xFFFF);
  const fs::path path = dir_ / "frame.exr";
  ASSERT_TRUE(WriteExrUint16(path, 64, 48, pixels, "Y", {{"loom.camera", std::string("cam0")}}).ok());
  const Result<ExrUint16Image> read = ReadExrUint16(path, "Y");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->pixels, pixels);
  EXPECT_EQ(std::get<std::string>(read->attributes.at("loom.camera")), "cam0");
  EXPECT_EQ(ReadExrUint16(path, "Z").status().code(), StatusCode::kNotFound);
  EXPECT_EQ(WriteExrUint16(path, 10, 10, pixels, "Y").code(), StatusCode::kInvalidArgument);
  // A float EXR is not a raw frame.
  ASSERT_TRUE(WriteExr(dir_ / "float.exr", RandomImage(4, 4, {"Y"}, 1)).ok());
  EXPECT_EQ(ReadExrUint16(dir_ / "float.exr", "Y").status().code(), StatusCode::kInvalidArgument);
}

TEST_F(ExrIoTest, BadReadAndWriteOptionsAreRefusedNamingTheField) {
  Image image(2, 2, {"Y"});
  ASSERT_TRUE(WriteExr(dir_ / "y.exr", image).ok());
  const Result<ExrImage> twice = ReadExr(dir_ / "y.exr", {.channels = {"Y", "Y"}});
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(twice.status().ToString().find("channels names 'Y' twice"), std::string::npos) << twice.status().ToString();
  EXPECT_NE(ExrReadOptions{.channels = {""}}.Check().ToString().find("empty name"), std::string::npos);
  ExrWriteOptions bad_write;
  bad_write.compression = static_cast<ExrCompression>(99);
  const Status written = WriteExr(dir_ / "bad.exr", image, {}, bad_write);
  ASSERT_FALSE(written.ok());
  EXPECT_NE(written.ToString().find("compression"), std::string::npos) << written.ToString();
  EXPECT_FALSE(std::filesystem::exists(dir_ / "bad.exr"));
}

}  // namespace
}  // namespace loom
