#include "scan/rig_state.h"

#include <gtest/gtest.h>

namespace loom::scan {
namespace {

TEST(ParseLedDrivesTest, ReadsWhatAnOperatorTypes) {
  const Result<std::vector<LedDrive>> drives = ParseLedDrives("3:500,7:1000.5,0:0", "--on");
  ASSERT_TRUE(drives.ok()) << drives.status().ToString();
  EXPECT_EQ(*drives, (std::vector<LedDrive>{{3, 500}, {7, 1000.5}, {0, 0}}));
}

TEST(ParseLedDrivesTest, RefusesAnythingElseNamingTheItem) {
  for (const char* text : {"", "3", "3:", ":500", "3:nan", "3:inf", "3:-1", "-1:500", "3x:500", "3:500mA", "1.5:500", "3:500,",
                           "3:500,3:200", "99999999999:1"}) {
    const Result<std::vector<LedDrive>> drives = ParseLedDrives(text, "--on");
    ASSERT_FALSE(drives.ok()) << "'" << text << "' was accepted";
    EXPECT_NE(drives.status().ToString().find(std::string("--on '") + text + "'"), std::string::npos)
        << drives.status().ToString();
  }
}

}  // namespace
}  // namespace loom::scan
