// loom scan on the simulated tac7-mini: a scan killed with SIGKILL at twenty points across its plan and resumed
// each time ends identical to an uninterrupted scan of the same seed — same frames, same pixels,
// none lost, none twice — and `loom scan --verify` finds it intact, then names a frame altered.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <thread>

#include "core/testing/build_tree.h"
#include "core/testing/subprocess.h"
#include "scan/capture_store.h"

namespace {

namespace fs = std::filesystem;
using loom::scan::CaptureStore;
using loom::testing::Subprocess;
using namespace std::chrono_literals;

class ScanCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / "scan_command_test";
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    preset_ = dir_ / "tiny.yaml";
    std::ofstream(preset_) << "schema_version: 1\npreset: tiny\nturntable_deg: [0, 90]\ncolour_views_deg: [0]\n"
                           << "linear_light_positions: 2\nmax_exposures: 3\n"
                           << "structured_light: {gray_bits: 2, phase_steps: 2}\n";
  }

  std::vector<std::string> ScanArgs(const fs::path& out) const {
    return {loom::testing::LoomBinary(),
            "scan",
            "--rig",
            loom::testing::SourceDir() + "/configs/rig/tac7-mini.yaml",
            "--preset",
            preset_.string(),
            "--object",
            "fabric:5",
            "--out",
            out.string(),
            "--quiet"};
  }

  // key → checksum of every frame of a scan, verified on the way.
  static std::map<std::string, std::string> Frames(const fs::path& scan) {
    const auto store = CaptureStore::Open(scan);
    EXPECT_TRUE(store.ok()) << store.status().ToString();
    std::map<std::string, std::string> frames;
    for (const auto& record : store->records()) {
      EXPECT_TRUE(store->ReadFrame(record).ok()) << record.file;
      const bool inserted = frames.emplace(record.file, record.checksum).second;
      EXPECT_TRUE(inserted) << "duplicate " << record.file;
    }
    return frames;
  }

  // Lines in a scan's journal so far (0 before it exists).
  static int JournalLines(const fs::path& scan) {
    std::ifstream journal(scan / "journal.jsonl");
    return static_cast<int>(std::count(std::istreambuf_iterator<char>(journal), std::istreambuf_iterator<char>(), '\n'));
  }

  fs::path dir_;
  fs::path preset_;
};

TEST_F(ScanCommandTest, KilledTwentyTimesAndResumedEqualsUninterrupted) {
  const fs::path reference = dir_ / "reference";
  auto whole = Subprocess::Start(ScanArgs(reference));
  ASSERT_TRUE(whole.ok());
  ASSERT_EQ(whole->Wait(), 0);
  const std::map<std::string, std::string> expected = Frames(reference);
  ASSERT_GT(expected.size(), 40u);

  // Twenty kills spread over the whole plan (dark, structured light, colour through the filter
  // wheels, point-lit, linear light): each when the journal reaches the next twenty-first of the
  // uninterrupted scan's lines; the last resume runs to the end.
  constexpr int kKills = 20;
  const fs::path interrupted = dir_ / "interrupted";
  const int total_lines = JournalLines(reference);
  int kills = 0;
  bool complete = false;
  for (int run = 0; run <= kKills && !complete; ++run) {
    const bool started = fs::exists(interrupted / "scan.yaml");
    std::vector<std::string> args =
        started ? std::vector<std::string>{loom::testing::LoomBinary(), "scan", "--resume", interrupted.string(), "--quiet"}
                : ScanArgs(interrupted);
    auto scan = Subprocess::Start(args);
    ASSERT_TRUE(scan.ok());
    if (run < kKills) {
      const auto deadline = std::chrono::steady_clock::now() + 120s;
      while (JournalLines(interrupted) < total_lines * (run + 1) / (kKills + 1) && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(2ms);
      }
      scan->Signal(SIGKILL);
    }
    const int code = scan->Wait();
    if (code == 0) {
      complete = true;
    } else {
      ASSERT_EQ(code, 128 + SIGKILL) << "run " << run << " failed by itself";
      ++kills;
    }
  }
  ASSERT_TRUE(complete);
  EXPECT_EQ(kills, kKills);
  EXPECT_EQ(Frames(interrupted), expected);

  // loom scan --verify: the resumed scan is intact; a frame altered afterwards is named, exit 1.
  const std::string verify = loom::testing::LoomBinary() + " scan --verify ";
  const auto intact = loom::testing::RunCommand(verify + interrupted.string());
  EXPECT_EQ(intact.exit_code, 0) << intact.output;
  EXPECT_NE(intact.output.find("intact"), std::string::npos) << intact.output;
  const std::string altered = (interrupted / Frames(interrupted).begin()->first).string();
  fs::copy_file(interrupted / std::prev(expected.end())->first, altered, fs::copy_options::overwrite_existing);
  const auto damaged = loom::testing::RunCommand(verify + interrupted.string());
  EXPECT_EQ(damaged.exit_code, 1) << damaged.output;
  EXPECT_NE(damaged.output.find("DAMAGED data loss: " + altered), std::string::npos) << damaged.output;
}

}  // namespace
