// loom's bad-input corpus (testdata/bad-input/cases.yaml): every case is a `loom` command line on
// hostile input that must end with its documented exit code and a message naming the culprit —
// never a crash, a hang or a silent success.
#include <gtest/gtest.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <ostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/testing/build_tree.h"
#include "core/testing/subprocess.h"

namespace {

namespace fs = std::filesystem;

const fs::path kCorpus = fs::path(loom::testing::SourceDir()) / "apps/testdata/bad-input";

struct BadInputCase {
  std::string name;
  YAML::Node node;
};
void PrintTo(const BadInputCase& c, std::ostream* out) { *out << c.name; }

std::vector<BadInputCase> LoadCases() {
  std::vector<BadInputCase> cases;
  for (const YAML::Node& node : YAML::LoadFile((kCorpus / "cases.yaml").string())["cases"]) {
    cases.push_back({node["name"].as<std::string>(), node});
  }
  return cases;
}

std::string ReplacedFirst(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "'" << from << "' is not in the file: the case no longer damages anything";
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::string Slurp(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string Substituted(std::string text, const fs::path& dir) {
  for (const auto& [key, value] : {std::pair<std::string, std::string>{"{dir}", dir.string()},
                                   std::pair<std::string, std::string>{"{configs}", loom::testing::SourceDir() + "/configs"}}) {
    for (size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + value.size())) {
      text.replace(at, key.size(), value);
    }
  }
  return text;
}

// The tiny scan the scan cases damage: rendered once by the CTest fixture
// (BadInputFixture.ScanTheTinyScanOnce, apps/CMakeLists.txt), else here.
fs::path TinyScan() {
  if (const char* scanned = std::getenv("LOOM_BAD_INPUT_SCAN"); scanned && fs::exists(fs::path(scanned) / "scan.yaml")) {
    return scanned;
  }
  static const fs::path scan = [] {
    const fs::path dir = fs::path(::testing::TempDir()) / ("bad_input_scan_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    const auto run = loom::testing::RunCommand(loom::testing::LoomBinary() + " scan --rig " + loom::testing::SourceDir() +
                                               "/configs/rig/tac7-mini.yaml --preset " + (kCorpus / "tiny-preset.yaml").string() +
                                               " --out " + dir.string() + " --quiet");
    EXPECT_EQ(run.exit_code, 0) << run.output;
    return dir;
  }();
  return scan;
}

// Writes what the case's command reads into `dir`.
void Prepare(const YAML::Node& c, const fs::path& dir) {
  if (const YAML::Node rig = c["rig"]) {
    std::string text = Slurp(fs::path(loom::testing::SourceDir()) / "configs/rig" / (rig["from"].as<std::string>() + ".yaml"));
    const YAML::Node replace = rig["replace"];
    for (size_t i = 0; i + 1 < replace.size(); i += 2) {
      text = ReplacedFirst(text, replace[i].as<std::string>(), replace[i + 1].as<std::string>());
    }
    std::ofstream(dir / "rig.yaml") << text;
  }
  if (const YAML::Node file = c["file"]) std::ofstream(dir / file["name"].as<std::string>()) << file["text"].as<std::string>();
  if (const YAML::Node bytes = c["bytes"]) {
    std::mt19937 random(7);
    std::ofstream out(dir / bytes["name"].as<std::string>(), std::ios::binary);
    for (int i = 0; i < bytes["count"].as<int>(); ++i) out.put(static_cast<char>(random() & 0xFF));
  }
  if (const YAML::Node scan = c["scan"]) {
    fs::copy(TinyScan(), dir / "scan", fs::copy_options::recursive);
    fs::remove(dir / "scan" / "writer.lock");
    for (const YAML::Node& edit : scan["edit"]) {
      const fs::path file = dir / "scan" / edit[0].as<std::string>();
      const std::string text = ReplacedFirst(Slurp(file), edit[1].as<std::string>(), edit[2].as<std::string>());
      std::ofstream(file, std::ios::trunc) << text;
    }
    for (const YAML::Node& file : scan["remove"]) EXPECT_TRUE(fs::remove(dir / "scan" / file.as<std::string>()));
  }
}

class BadInputTest : public ::testing::TestWithParam<BadInputCase> {};

TEST_P(BadInputTest, IsRefusedWithItsExitCodeNamingTheCulprit) {
  const YAML::Node& c = GetParam().node;
  const fs::path dir = fs::path(::testing::TempDir()) / ("bad_input_" + GetParam().name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  Prepare(c, dir);
  if (HasFailure()) return;
  // `timeout`: a case that hangs fails (exit 124) instead of stalling the suite.
  const auto run = loom::testing::RunCommand("timeout 60 " + loom::testing::LoomBinary() + " " +
                                             Substituted(c["command"].as<std::string>(), dir));
  EXPECT_EQ(run.exit_code, c["exit"].as<int>()) << run.output;
  const std::string names = Substituted(c["names"].as<std::string>(), dir);
  EXPECT_NE(run.output.find(names), std::string::npos) << "expected '" << names << "' in:\n" << run.output;
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadInputTest, ::testing::ValuesIn(LoadCases()),
                         [](const ::testing::TestParamInfo<BadInputCase>& info) { return info.param.name; });

}  // namespace
