#include "core/log.h"

#include <gtest/gtest.h>

#include <sstream>

namespace loom {
namespace {

class LogTest : public ::testing::Test {
 protected:
  void SetUp() override {
    saved_ = GetLogLevel();
    SetLogStream(&captured_);
  }
  void TearDown() override {
    SetLogStream(nullptr);
    SetLogLevel(saved_);
  }
  std::ostringstream captured_;
  LogLevel saved_ = LogLevel::kInfo;
};

TEST_F(LogTest, WritesLevelFileAndMessage) {
  SetLogLevel(LogLevel::kInfo);
  LOOM_LOG(Warning) << "filter wheel " << 3 << " slow";
  const std::string line = captured_.str();
  EXPECT_EQ(line.front(), 'W');
  EXPECT_NE(line.find("log_test.cc:"), std::string::npos) << line;
  EXPECT_NE(line.find("filter wheel 3 slow\n"), std::string::npos) << line;
}

TEST_F(LogTest, BelowThresholdIsNotEvaluated) {
  SetLogLevel(LogLevel::kWarning);
  int evaluated = 0;
  LOOM_LOG(Info) << ++evaluated;
  LOOM_LOG(Debug) << ++evaluated;
  EXPECT_EQ(evaluated, 0);
  EXPECT_TRUE(captured_.str().empty());
}

TEST(LogLevelTest, Parses) {
  EXPECT_EQ(*ParseLogLevel("DEBUG"), LogLevel::kDebug);
  EXPECT_EQ(*ParseLogLevel("warning"), LogLevel::kWarning);
  EXPECT_EQ(*ParseLogLevel("off"), LogLevel::kOff);
  const Result<LogLevel> bad = ParseLogLevel("loud");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().ToString().find("'loud'"), std::string::npos);
}

}  // namespace
}  // namespace loom
