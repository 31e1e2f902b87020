#include "core/output_directory.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

namespace loom {
namespace {

namespace fs = std::filesystem;

class OutputDirectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::path(::testing::TempDir()) / ("output_directory_" + std::to_string(::getpid()) + "_" +
                                              ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }
  fs::path root_;
};

TEST_F(OutputDirectoryTest, AppearsWholeOnCommitAndNotAtAllOtherwise) {
  {
    Result<OutputDirectory> out = OutputDirectory::Create(root_ / "fit", "--out");
    ASSERT_TRUE(out.ok()) << out.status().ToString();
    std::ofstream(out->partial() / "maps.exr") << "maps";
    EXPECT_FALSE(fs::exists(root_ / "fit"));  // not before it is complete
    ASSERT_TRUE(out->Commit().ok());
  }
  EXPECT_TRUE(fs::exists(root_ / "fit" / "maps.exr"));
  {
    Result<OutputDirectory> failed = OutputDirectory::Create(root_ / "other", "--out");
    ASSERT_TRUE(failed.ok());
    std::ofstream(failed->partial() / "half.exr") << "half";
  }  // a failed run: never committed
  EXPECT_FALSE(fs::exists(root_ / "other"));
  EXPECT_EQ(std::distance(fs::directory_iterator(root_), fs::directory_iterator()), 1);  // only fit/
}

TEST_F(OutputDirectoryTest, AnErrorInsideThePartialDirectoryNamesTheFinalPath) {
  std::string error;
  {
    Result<OutputDirectory> out = OutputDirectory::Create(root_ / "model", "--out");
    ASSERT_TRUE(out.ok());
    error = (out->partial() / "weights.pt").string() + ": cannot write: No space left on device";
  }  // failed: the partial directory is gone before the error is printed
  EXPECT_EQ(OutputDirectory::InUsersTerms(error),
            (root_ / "model" / "weights.pt").string() + ": cannot write: No space left on device");
  EXPECT_EQ(OutputDirectory::InUsersTerms("elsewhere: no such file"), "elsewhere: no such file");
}

TEST_F(OutputDirectoryTest, NeverReplacesWhatIsThereAndTidiesAKilledRunsPartialDirectory) {
  fs::create_directories(root_ / "fit");
  std::ofstream(root_ / "fit" / "notes.txt") << "the user's";
  const Result<OutputDirectory> over = OutputDirectory::Create(root_ / "fit", "--out");
  ASSERT_FALSE(over.ok());
  EXPECT_EQ(over.status().code(), StatusCode::kAlreadyExists);
  EXPECT_NE(over.status().ToString().find("--out " + (root_ / "fit").string()), std::string::npos) << over.status().ToString();
  EXPECT_TRUE(fs::exists(root_ / "fit" / "notes.txt"));
  std::ofstream(root_ / "file") << "x";
  EXPECT_FALSE(OutputDirectory::Create(root_ / "file", "--out").ok());

  fs::create_directories(root_ / ".rec.partial-2147483646");                      // a killed run's (no such process)
  const fs::path live = root_ / (".rec.partial-" + std::to_string(::getppid()));  // a live process's
  fs::create_directories(live);
  fs::create_directories(root_ / "rec");  // empty: fine
  Result<OutputDirectory> out = OutputDirectory::Create(root_ / "rec/", "--out");
  ASSERT_TRUE(out.ok()) << out.status().ToString();
  EXPECT_FALSE(fs::exists(root_ / ".rec.partial-2147483646"));
  EXPECT_TRUE(fs::exists(live));
  ASSERT_TRUE(out->Commit().ok());
  EXPECT_TRUE(fs::is_directory(root_ / "rec"));
}

// A recalibration's output: the old one stays whole until the new one is complete, then the new
// one stands whole in its place — never a mix of the two, never neither.
TEST_F(OutputDirectoryTest, AReplacingOutputSwapsInWholeOrLeavesTheOldOneAsItWas) {
  const fs::path radiometry = root_ / "radiometry";
  fs::create_directories(radiometry);
  std::ofstream(radiometry / "cam0.yaml") << "old";
  std::ofstream(radiometry / "wheel1.yaml") << "old";  // a file the new output does not have
  {
    Result<OutputDirectory> failed = OutputDirectory::Replacing(radiometry, "radiometry");
    ASSERT_TRUE(failed.ok()) << failed.status().ToString();
    std::ofstream(failed->partial() / "cam0.yaml") << "half";
  }  // never committed
  std::ifstream old(radiometry / "cam0.yaml");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(old), {}), "old");
  EXPECT_TRUE(fs::exists(radiometry / "wheel1.yaml"));

  Result<OutputDirectory> out = OutputDirectory::Replacing(radiometry, "radiometry");
  ASSERT_TRUE(out.ok()) << out.status().ToString();
  std::ofstream(out->partial() / "cam0.yaml") << "new";
  ASSERT_TRUE(out->Commit().ok());
  std::ifstream replaced(radiometry / "cam0.yaml");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(replaced), {}), "new");
  EXPECT_FALSE(fs::exists(radiometry / "wheel1.yaml"));
  EXPECT_EQ(std::distance(fs::directory_iterator(root_), fs::directory_iterator()), 1);  // the old one is gone

  Result<OutputDirectory> fresh = OutputDirectory::Replacing(root_ / "new", "radiometry");  // nothing to replace
  ASSERT_TRUE(fresh.ok());
  ASSERT_TRUE(fresh->Commit().ok());
  EXPECT_TRUE(fs::is_directory(root_ / "new"));
  std::ofstream(root_ / "file") << "x";
  const Result<OutputDirectory> over_file = OutputDirectory::Replacing(root_ / "file", "radiometry");
  ASSERT_FALSE(over_file.ok());
  EXPECT_NE(over_file.status().ToString().find("radiometry " + (root_ / "file").string()), std::string::npos);
}

}  // namespace
}  // namespace loom
