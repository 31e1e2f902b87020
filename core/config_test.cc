#include "core/config.h"

#include <gtest/gtest.h>

#include <fstream>

namespace loom {
namespace {

constexpr int kSchema = 2;

struct CameraOptions {
  std::string name;
  double exposure_us = 1000.0;
  int gain = 0;
};

// A small reader in the style every loom config uses.
Status ReadCameras(const ConfigDocument& doc, std::vector<CameraOptions>* cameras) {
  for (const ConfigNode& node : doc.root().Sequence("cameras")) {
    CameraOptions camera;
    node.Required("name", &camera.name);
    node.Optional("exposure_us", &camera.exposure_us);
    node.Optional("gain", &camera.gain);
    if (camera.exposure_us <= 0) node.AddError("exposure_us", "must be > 0");
    cameras->push_back(camera);
  }
  return doc.Finish();
}

TEST(ConfigTest, ReadsValuesAndDefaults) {
  const auto doc = ConfigDocument::LoadString(R"(
schema_version: 2
cameras:
  - {name: cam0, exposure_us: 250}
  - {name: cam1, gain: 3}
)",
                                              "rig.yaml", kSchema);
  ASSERT_TRUE(doc.ok()) << doc.status().ToString();
  EXPECT_EQ(doc->schema_version(), 2);
  std::vector<CameraOptions> cameras;
  ASSERT_TRUE(ReadCameras(*doc, &cameras).ok());
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0].exposure_us, 250.0);
  EXPECT_EQ(cameras[1].exposure_us, 1000.0);
  EXPECT_EQ(cameras[1].gain, 3);
}

TEST(ConfigTest, UnknownKeyNamesFileKeyLineAndSuggests) {
  const auto doc = ConfigDocument::LoadString("schema_version: 1\ncameras:\n  - name: cam0\n    exposur_us: 250\n",
                                              "configs/rig/x.yaml", kSchema);
  ASSERT_TRUE(doc.ok());
  std::vector<CameraOptions> cameras;
  const Status status = ReadCameras(*doc, &cameras);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.subject(), "configs/rig/x.yaml");
  EXPECT_NE(status.message().find("key 'cameras[0].exposur_us' (line 4): unknown key"), std::string::npos) << status.message();
  EXPECT_NE(status.message().find("did you mean 'exposure_us'?"), std::string::npos);
}

// Found by fuzzing (core/fuzz): a key that is a list or a map is valid YAML, and converting it to
// a name threw from Finish() — an exception where a message naming the line belongs.
TEST(ConfigTest, AKeyThatIsAListOrAMapIsNamedNotThrown) {
  const auto top = ConfigDocument::LoadString("schema_version: 1\n? [a, b]\n: 3\n", "rig.yaml", 1);
  ASSERT_FALSE(top.ok());
  EXPECT_NE(top.status().ToString().find("line 2: a key must be a plain name, not a list"), std::string::npos)
      << top.status().ToString();
  const auto nested = ConfigDocument::LoadString("schema_version: 1\ncamera:\n  {x: 1}: 2\n", "rig.yaml", 1);
  ASSERT_TRUE(nested.ok()) << nested.status().ToString();
  EXPECT_TRUE(nested->root().Child("camera").Keys().empty());
  Status finished;
  EXPECT_NO_THROW(finished = nested->Finish());
  EXPECT_NE(finished.ToString().find("key 'camera' (line 3): a key must be a plain name"), std::string::npos)
      << finished.ToString();
}

TEST(ConfigTest, ReportsEveryProblemAtOnce) {
  const auto doc = ConfigDocument::LoadString(R"(
schema_version: 2
cameras:
  - {exposure_us: fast}
  - {name: cam1, exposure_us: -5}
turntable: {}
)",
                                              "rig.yaml", kSchema);
  ASSERT_TRUE(doc.ok());
  std::vector<CameraOptions> cameras;
  const Status status = ReadCameras(*doc, &cameras);
  ASSERT_FALSE(status.ok());
  const std::string& m = status.message();
  EXPECT_NE(m.find("4 problems"), std::string::npos) << m;
  EXPECT_NE(m.find("key 'cameras[0].name' (line 4): missing required key"), std::string::npos) << m;
  EXPECT_NE(m.find("key 'cameras[0].exposure_us' (line 4): expected a number, got 'fast'"), std::string::npos) << m;
  EXPECT_NE(m.find("key 'cameras[1].exposure_us' (line 5): must be > 0"), std::string::npos) << m;
  EXPECT_NE(m.find("key 'turntable' (line 6): unknown key"), std::string::npos) << m;
}

TEST(ConfigTest, SchemaVersionIsRequiredAndBounded) {
  const auto missing = ConfigDocument::LoadString("cameras: []\n", "a.yaml", kSchema);
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().ToString().find("'schema_version'"), std::string::npos);
  const auto newer = ConfigDocument::LoadString("schema_version: 3\n", "a.yaml", kSchema);
  ASSERT_FALSE(newer.ok());
  EXPECT_NE(newer.status().ToString().find("version 3 is not supported"), std::string::npos);
}

TEST(ConfigTest, TypedValues) {
  const auto doc = ConfigDocument::LoadString(R"(
schema_version: 1
enabled: yes
position_mm: [1, 2.5, -3]
rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
names: [a, b]
bad_vector: [1, 2]
)",
                                              "t.yaml", 1);
  ASSERT_TRUE(doc.ok());
  const ConfigNode root = doc->root();
  bool enabled = false;
  Eigen::Vector3d position;
  Eigen::Matrix3d rotation;
  std::vector<std::string> names;
  Eigen::Vector3d bad;
  root.Required("enabled", &enabled);
  root.Required("position_mm", &position);
  root.Required("rotation", &rotation);
  root.Required("names", &names);
  root.Required("bad_vector", &bad);
  EXPECT_TRUE(enabled);
  EXPECT_EQ(position, Eigen::Vector3d(1, 2.5, -3));
  EXPECT_TRUE(rotation.isIdentity());
  EXPECT_EQ(names, (std::vector<std::string>{"a", "b"}));
  const Status status = doc->Finish();
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("key 'bad_vector' (line 7): expected a list of 3 numbers, got 2"), std::string::npos)
      << status.message();
}

TEST(ConfigTest, NumbersThatAreNotFiniteAreRefusedWhereverTheyAre) {
  const auto doc = ConfigDocument::LoadString(R"(
schema_version: 1
pixel_mm: .nan
limit_ma: -.inf
position_mm: [.nan, 0, 600]
weights: [1, .inf]
rotation: [[1, 0, 0], [0, .NaN, 0], [0, 0, 1]]
fine: 1e-3
)",
                                              "t.yaml", 1);
  ASSERT_TRUE(doc.ok());
  const ConfigNode root = doc->root();
  double pixel_mm = 0.2, fine = 0;
  float limit_ma = 1000;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  std::vector<double> weights;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  root.Required("pixel_mm", &pixel_mm);
  root.Required("limit_ma", &limit_ma);
  root.Required("position_mm", &position);
  root.Required("weights", &weights);
  root.Required("rotation", &rotation);
  root.Required("fine", &fine);
  EXPECT_EQ(pixel_mm, 0.2);  // the defaults are kept
  EXPECT_EQ(limit_ma, 1000);
  EXPECT_EQ(fine, 1e-3);
  const Status status = doc->Finish();
  ASSERT_FALSE(status.ok());
  for (const char* expected : {"key 'pixel_mm' (line 3): expected a finite number, got '.nan'",
                               "key 'limit_ma' (line 4): expected a finite number, got '-.inf'",
                               "key 'position_mm' (line 5): element 0: expected a finite number",
                               "key 'weights' (line 6): element 1: expected a finite number",
                               "key 'rotation' (line 7): row 1: element 1: expected a finite number"}) {
    EXPECT_NE(status.message().find(expected), std::string::npos) << expected << "\n" << status.message();
  }
}

TEST(ConfigTest, FileErrorsNameTheFile) {
  const auto missing = ConfigDocument::LoadFile("/nonexistent/rig.yaml", 1);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
  EXPECT_EQ(missing.status().subject(), "/nonexistent/rig.yaml");

  const std::filesystem::path path = std::filesystem::path(testing::TempDir()) / "broken.yaml";
  std::ofstream(path) << "schema_version: 1\ncameras: [unclosed\n";
  const auto broken = ConfigDocument::LoadFile(path, 1);
  ASSERT_FALSE(broken.ok());
  EXPECT_EQ(broken.status().subject(), path.string());
  EXPECT_NE(broken.status().message().find("not valid YAML"), std::string::npos);

  for (const char* not_a_config : {"/dev/zero", "/tmp"}) {
    const auto device = ConfigDocument::LoadFile(not_a_config, 1);
    ASSERT_FALSE(device.ok()) << not_a_config;
    EXPECT_EQ(device.status().subject(), not_a_config);
    EXPECT_NE(device.status().message().find("not a regular file"), std::string::npos) << device.status().ToString();
  }
  std::filesystem::resize_file(path, (16 << 20) + 1);  // a data file given by mistake
  const auto huge = ConfigDocument::LoadFile(path, 1);
  ASSERT_FALSE(huge.ok());
  EXPECT_NE(huge.status().message().find("too large"), std::string::npos) << huge.status().ToString();
  std::filesystem::remove(path);
}

TEST(ConfigTest, IgnoredSectionsAreNotUnknown) {
  const auto doc = ConfigDocument::LoadString("schema_version: 1\ngeometry: {a: 1}\ndevices: {b: 2}\n", "r.yaml", 1);
  ASSERT_TRUE(doc.ok());
  int a = 0;
  doc->root().Child("geometry").Required("a", &a);
  doc->root().Ignore("devices");
  doc->root().Ignore("sample");  // absent: fine
  EXPECT_TRUE(doc->Finish().ok()) << doc->Finish().ToString();
}

TEST(ConfigTest, NestedChildrenAndMissingChild) {
  const auto doc =
      ConfigDocument::LoadString("schema_version: 1\nturntable:\n  backend: sim\n  axis: {point_mm: [0, 0, 0]}\n", "r.yaml", 1);
  ASSERT_TRUE(doc.ok());
  const ConfigNode turntable = doc->root().Child("turntable");
  std::string backend;
  turntable.Required("backend", &backend);
  Eigen::Vector3d point;
  turntable.Child("axis").Required("point_mm", &point);
  turntable.Child("limits");
  EXPECT_EQ(turntable.path(), "turntable");
  EXPECT_EQ(backend, "sim");
  const Status status = doc->Finish();
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("key 'turntable.limits' (line 3): missing required key"), std::string::npos)
      << status.message();
}

}  // namespace
}  // namespace loom
