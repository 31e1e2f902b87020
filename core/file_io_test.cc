#include "core/file_io.h"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <fstream>

#include "core/exr_io.h"
#include "core/memory.h"
#include "core/output_directory.h"
#include "core/output_file.h"
#include "core/version.h"

namespace loom {
namespace {

namespace fs = std::filesystem;

class OutputRuleTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::path(::testing::TempDir()) /
            ("output_rule_" + std::to_string(::getpid()) + "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
    fs::create_directories(root_ / "folder");
    std::ofstream(root_ / "regular") << "the user's";
    fs::create_symlink("nowhere", root_ / "dangling");
    fs::create_symlink("loop", root_ / "loop");
    fs::create_directory_symlink("folder", root_ / "to-folder");
    fs::create_symlink("regular", root_ / "to-regular");
    ASSERT_EQ(::mkfifo((root_ / "fifo").c_str(), 0644), 0);
    socket_ = ::socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    const std::string socket_path = (root_ / "socket").string();
    ASSERT_LT(socket_path.size(), sizeof address.sun_path);
    socket_path.copy(address.sun_path, socket_path.size());
    ASSERT_EQ(::bind(socket_, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  }
  void TearDown() override {
    ::close(socket_);
    fs::remove_all(root_);
  }
  // What is at `name` now, as lstat sees it: the test's proof that nothing was replaced.
  static mode_t KindAt(const fs::path& path) {
    struct stat info {};
    return ::lstat(path.c_str(), &info) == 0 ? (info.st_mode & S_IFMT) : 0;
  }
  fs::path root_;
  int socket_ = -1;
};

TEST_F(OutputRuleTest, AFileOutputReplacesOnlyARegularFileAndNamesThePathItRefuses) {
  const Image image(2, 2, {"Y"});
  for (const char* name : {"dangling", "loop", "to-folder", "to-regular", "fifo", "socket", "folder"}) {
    const fs::path path = root_ / name;
    const mode_t before = KindAt(path);
    const Status text = WriteFileAtomically(path, "new");
    const Status exr = WriteExr(path, image);
    for (const Status& status : {text, exr}) {
      ASSERT_FALSE(status.ok()) << name;
      EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition) << name;
      EXPECT_EQ(status.subject(), path.string()) << status.ToString();
    }
    EXPECT_EQ(KindAt(path), before) << name << " was replaced";
  }
  const Status device = CheckReplaceableFile("/dev/null");  // checked only: as root a write would replace the device
  EXPECT_NE(device.ToString().find("/dev/null: is a device"), std::string::npos) << device.ToString();
  EXPECT_TRUE(WriteFileAtomically(root_ / "regular", "new").ok());
  EXPECT_TRUE(WriteFileAtomically(root_ / "new", "new").ok());
  EXPECT_EQ(ReadFile(root_ / "regular").value(), "new");
  EXPECT_EQ(std::distance(fs::directory_iterator(root_), fs::directory_iterator()), 9) << "a temporary left behind";
}

TEST_F(OutputRuleTest, AnOutputFolderIsNeverALinkOrSpecialFileAndItsErrorsNameTheUsersPath) {
  for (const char* name : {"dangling", "loop", "to-folder", "fifo", "socket"}) {
    const fs::path path = root_ / name;
    const mode_t before = KindAt(path);
    const Result<OutputDirectory> out = OutputDirectory::Create(path, "--out");
    ASSERT_FALSE(out.ok()) << name;
    EXPECT_EQ(out.status().subject(), "--out " + path.string());
    EXPECT_EQ(KindAt(path), before) << name << " was replaced";
  }
  const Result<OutputDirectory> unwritable = OutputDirectory::Create(root_ / "regular" / "fit", "--out");
  ASSERT_FALSE(unwritable.ok());
  EXPECT_EQ(unwritable.status().subject(), "--out " + (root_ / "regular" / "fit").string());
  EXPECT_EQ(unwritable.status().message().find(".partial"), std::string::npos) << unwritable.status().ToString();
  const Status missing = CheckOutputFolderExists(root_ / "no-such-folder" / "m.axf", "--axf");
  EXPECT_NE(missing.ToString().find("--axf " + (root_ / "no-such-folder" / "m.axf").string()), std::string::npos);
  EXPECT_TRUE(CheckOutputFolderExists(root_ / "m.axf", "--axf").ok());
}

// A minimal PNG's bytes (signature, a 1 × 1 grey IHDR, IEND): enough for the marker's chunk walk.
std::string TinyPng() {
  std::string png("\x89PNG\r\n\x1a\n", 8);
  // Length 13, "IHDR", width 1, height 1, 8-bit grey, no interlace: 21 bytes before its CRC.
  png += std::string("\0\0\0\x0dIHDR\0\0\0\x01\0\0\0\x01\x08\0\0\0\0", 21);
  png += std::string("\0\0\0\0", 4);  // the header's CRC, which the walk does not check
  png += std::string("\0\0\0\0IEND\xae\x42\x60\x82", 12);
  return png;
}

TEST_F(OutputRuleTest, AUsersOutputFileReplacesOnlyWhatLoomWroteUnlessForced) {
  const fs::path exr = root_ / "stack.exr";
  ASSERT_TRUE(WriteExr(exr, Image(2, 2, {"Y"})).ok());
  ASSERT_TRUE(WriteFileAtomically(root_ / "report.json", "{\"loom_version\": \"0\", \"x\": 1}\n").ok());
  ASSERT_TRUE(WriteFileAtomically(root_ / "theirs.json", "{\"x\": 1}\n").ok());
  ASSERT_TRUE(WriteFileAtomically(root_ / "emulation.yaml", std::string(kLoomTextMarker) + " 0\nschema_version: 1\n").ok());
  ASSERT_TRUE(WriteFileAtomically(root_ / "theirs.yaml", "schema_version: 1\n").ok());
  ASSERT_TRUE(WriteFileAtomically(root_ / "frame.png", MarkPngAsLoomOutput(TinyPng())).ok());
  ASSERT_TRUE(WriteFileAtomically(root_ / "theirs.png", TinyPng()).ok());
  for (const char* ours : {"stack.exr", "report.json", "emulation.yaml", "frame.png"}) {
    EXPECT_TRUE(HasLoomMarker(root_ / ours)) << ours;
    EXPECT_TRUE(CheckOutputFile(root_ / ours, "--out", false).ok()) << ours;
  }
  EXPECT_TRUE(CheckOutputFile(root_ / "new.exr", "--out", false).ok());
  for (const char* theirs : {"regular", "theirs.json", "theirs.yaml", "theirs.png"}) {
    const fs::path path = root_ / theirs;
    EXPECT_FALSE(HasLoomMarker(path)) << theirs;
    const Status refused = CheckOutputFile(path, "--json", false);
    ASSERT_FALSE(refused.ok()) << theirs;
    EXPECT_EQ(refused.subject(), "--json " + path.string());
    EXPECT_NE(refused.message().find("--force"), std::string::npos) << refused.ToString();
    EXPECT_TRUE(CheckOutputFile(path, "--json", true).ok()) << theirs;
  }
  EXPECT_EQ(MarkPngAsLoomOutput(TinyPng()).size(), TinyPng().size() + 12 + 9 + 5 + VersionWithCommit().size());
  EXPECT_FALSE(CheckOutputFile(root_ / "to-regular", "--out", true).ok()) << "--force never replaces a link";
  EXPECT_FALSE(CheckOutputFile(root_ / "fifo", "--out", true).ok());
  EXPECT_FALSE(CheckOutputFile(root_ / "folder", "--out", true).ok());
  EXPECT_FALSE(HasLoomMarker(root_ / "fifo")) << "a FIFO is never read";
}

TEST(MemoryTest, ASizeBeyondTheMachineIsRefusedNamingWhatAskedAndHowMuch) {
  const uint64_t available = AvailableMemoryBytes();
  ASSERT_GT(available, 0u);
  EXPECT_TRUE(CheckFitsInMemory(available / 2, "--size 64").ok());
  const Status huge = CheckFitsInMemory(available * 4, "--size 16384");
  ASSERT_FALSE(huge.ok());
  EXPECT_EQ(huge.subject(), "--size 16384");
  EXPECT_NE(huge.message().find(ReadableBytes(available * 4)), std::string::npos) << huge.message();
  EXPECT_EQ(ReadableBytes(320'000'000), "320 MB");
  EXPECT_EQ(ReadableBytes(1'500'000'000), "1.5 GB");
  EXPECT_EQ(ReadableBytes(64'000'000'000), "64 GB");
}

}  // namespace
}  // namespace loom
