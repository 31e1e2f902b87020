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

}  // namespace
}  // namespace loom
