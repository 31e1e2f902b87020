#include "core/check.h"

#include <gtest/gtest.h>

namespace loom {
namespace {

TEST(CheckTest, PassingCheckDoesNothing) {
  int evaluated = 0;
  LOOM_CHECK(true) << "never " << ++evaluated;
  LOOM_CHECK_EQ(2, 2);
  LOOM_CHECK_LT(1, 2);
  EXPECT_EQ(evaluated, 0);  // the message is not built when the check passes
}

TEST(CheckTest, FailingCheckThrowsWithLocationConditionAndMessage) {
  try {
    const int width = 0;
    LOOM_CHECK(width > 0) << "image 'x' has width " << width;
    FAIL() << "no throw";
  } catch (const CheckError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("check_test.cc"), std::string::npos) << what;
    EXPECT_NE(what.find("width > 0"), std::string::npos) << what;
    EXPECT_NE(what.find("image 'x' has width 0"), std::string::npos) << what;
  }
}

TEST(CheckTest, ComparisonShowsBothValues) {
  try {
    const size_t a = 3;
    const size_t b = 4;
    LOOM_CHECK_EQ(a, b) << "sizes";
    FAIL() << "no throw";
  } catch (const CheckError& e) {
    EXPECT_NE(std::string(e.what()).find("(3 vs 4)"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace loom
