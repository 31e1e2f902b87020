// loom's bad-input corpus (testdata/bad-input/cases.yaml): every case is a `loom` command line on
// hostile input that must end with its documented exit code and a message naming the culprit —
// never a crash, a hang or a silent success — and leave its folder as it was.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
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

// Runs `loom ARGUMENTS` for a case's setup; a failure fails the case.
void RunLoom(const std::string& arguments) {
  const auto run = loom::testing::RunCommand(loom::testing::LoomBinary() + " " + arguments);
  EXPECT_EQ(run.exit_code, 0) << arguments << ":\n" << run.output;
}

// The model the model cases damage: a copy of tac7-mini's with `edit` substitutions in its
// model.json and weights.pt cut to `weights_bytes` when given.
void PrepareModel(const YAML::Node& model, const fs::path& dir) {
  const fs::path from = fs::path(loom::testing::SourceDir()) / "configs/models/tac7-mini";
  fs::create_directories(dir / "model");
  for (const char* file : {"model.json", "weights.pt", "refine.json"}) fs::copy_file(from / file, dir / "model" / file);
  std::string info = Slurp(dir / "model" / "model.json");
  for (const YAML::Node& edit : model["edit"]) info = ReplacedFirst(info, edit[0].as<std::string>(), edit[1].as<std::string>());
  std::ofstream(dir / "model" / "model.json", std::ios::trunc) << info;
  if (const YAML::Node bytes = model["weights_bytes"]) fs::resize_file(dir / "model" / "weights.pt", bytes.as<uintmax_t>());
  for (const YAML::Node& file : model["remove"]) fs::remove(dir / "model" / file.as<std::string>());
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
  if (const YAML::Node file = c["file"]) {
    fs::create_directories((dir / file["name"].as<std::string>()).parent_path());
    std::ofstream(dir / file["name"].as<std::string>()) << file["text"].as<std::string>();
  }
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
  if (c["material"]) RunLoom("sim material --size 16 --out " + (dir / "material").string());
  if (c["stack"]) {
    RunLoom("sim render --rig " + loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml --stack --size 6 --out " +
            (dir / "stack.exr").string());
  }
  if (const YAML::Node model = c["model"]) PrepareModel(model, dir);
  for (const YAML::Node& link : c["links"]) fs::create_symlink(link[1].as<std::string>(), dir / link[0].as<std::string>());
  if (const YAML::Node fifo = c["fifo"]) {
    EXPECT_EQ(::mkfifo((dir / fifo.as<std::string>()).c_str(), 0644), 0);
  }
}

// Everything under `dir` as lstat sees it (links not followed): kind, and for files size and
// modification time, per path. A refused command must leave it as it was — but for a scan's
// writer.lock, which opening a scan to resume it takes (and which holds no data).
std::map<std::string, std::string> Snapshot(const fs::path& dir) {
  std::map<std::string, std::string> entries;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.path().filename() == "writer.lock") continue;
    struct stat info {};
    ::lstat(entry.path().c_str(), &info);
    std::string state = std::to_string(info.st_mode);
    if (S_ISREG(info.st_mode)) {
      state += " " + std::to_string(info.st_size) + " " + std::to_string(info.st_mtim.tv_sec) + "." +
               std::to_string(info.st_mtim.tv_nsec);
    }
    entries[entry.path().lexically_relative(dir).string()] = state;
  }
  return entries;
}

class BadInputTest : public ::testing::TestWithParam<BadInputCase> {};

TEST_P(BadInputTest, IsRefusedWithItsExitCodeNamingTheCulprit) {
  const YAML::Node& c = GetParam().node;
  const fs::path dir = fs::path(::testing::TempDir()) / ("bad_input_" + GetParam().name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  Prepare(c, dir);
  if (HasFailure()) return;
  const std::map<std::string, std::string> before = Snapshot(dir);
  // `timeout`: a case that hangs fails (exit 124) instead of stalling the suite.
  const auto run = loom::testing::RunCommand("timeout 60 " + loom::testing::LoomBinary() + " " +
                                             Substituted(c["command"].as<std::string>(), dir));
  EXPECT_EQ(run.exit_code, c["exit"].as<int>()) << run.output;
  const std::string names = Substituted(c["names"].as<std::string>(), dir);
  EXPECT_NE(run.output.find(names), std::string::npos) << "expected '" << names << "' in:\n" << run.output;
  EXPECT_EQ(Snapshot(dir), before) << "a refused command wrote, replaced or removed something in " << dir;
  EXPECT_EQ(run.output.find("frame #"), std::string::npos) << "a library's backtrace reached the user:\n" << run.output;
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadInputTest, ::testing::ValuesIn(LoadCases()),
                         [](const ::testing::TestParamInfo<BadInputCase>& info) { return info.param.name; });

}  // namespace
