// The CNN engine's module, loaded as loom loads it (internal/cnn_engine.h).
#include "fitting/cnn/internal/cnn_engine.h"

#include <gtest/gtest.h>

#include <string>

namespace loom::fitting::internal {
namespace {

bool Contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

TEST(CnnEngineTest, TheBuiltModuleLoadsOnceAndMakesModels) {
  const Result<const CnnEngine*> engine = BuiltCnnEngine();
  ASSERT_TRUE(engine.ok()) << engine.status().ToString();
  EXPECT_EQ(*BuiltCnnEngine(), *engine);
  CnnModelInfo info;
  info.architecture = {.input_channels = 6, .width_divisor = 32, .dropout = 0};
  const Result<Cnn> cnn = (*engine)->Create(info, 1);
  ASSERT_TRUE(cnn.ok()) << cnn.status().ToString();
  EXPECT_EQ(cnn->info().architecture.input_channels, 6);
}

TEST(CnnEngineTest, AMissingModuleIsNamed) {
  const Result<const CnnEngine*> engine = LoadCnnEngine("/nonexistent/libloom_cnn_torch.so");
  ASSERT_FALSE(engine.ok());
  EXPECT_EQ(engine.status().code(), StatusCode::kUnavailable);
  EXPECT_TRUE(Contains(engine.status().ToString(), "/nonexistent/libloom_cnn_torch.so")) << engine.status().ToString();
}

// A shared library that is not loom's CNN module (glibc's libm): refused by its entry point's
// absence, never called.
TEST(CnnEngineTest, ALibraryWithoutTheEntryPointIsRefused) {
  const Result<const CnnEngine*> engine = LoadCnnEngine("libm.so.6");
  ASSERT_FALSE(engine.ok());
  EXPECT_EQ(engine.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_TRUE(Contains(engine.status().ToString(), "libm.so.6")) << engine.status().ToString();
  EXPECT_TRUE(Contains(engine.status().ToString(), kCnnEngineEntry)) << engine.status().ToString();
}

}  // namespace
}  // namespace loom::fitting::internal
