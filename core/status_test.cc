#include "core/status.h"

#include <gtest/gtest.h>

#include "core/check.h"

namespace loom {
namespace {

TEST(StatusTest, OkByDefault) {
  EXPECT_TRUE(Status().ok());
  EXPECT_EQ(Status().ToString(), "ok");
}

TEST(StatusTest, MessageNamesSubject) {
  const Status status = NotFoundError("/scan/frame_0012.png", "no such file");
  EXPECT_FALSE(status.ok());
  EXPECT_EQ(status.code(), StatusCode::kNotFound);
  EXPECT_EQ(status.subject(), "/scan/frame_0012.png");
  EXPECT_EQ(status.ToString(), "not found: /scan/frame_0012.png: no such file");
}

TEST(StatusTest, ContextKeepsSubject) {
  const Status status = TimeoutError("camera cam2 (192.168.1.12)", "no frame within 500 ms").WithContext("capturing step 17");
  EXPECT_EQ(status.subject(), "camera cam2 (192.168.1.12)");
  EXPECT_EQ(status.ToString(), "timeout: camera cam2 (192.168.1.12): capturing step 17: no frame within 500 ms");
}

Result<int> Half(int x) {
  if (x % 2 != 0) return InvalidArgumentError("x", "odd: " + std::to_string(x));
  return x / 2;
}

Result<int> Quarter(int x) {
  LOOM_ASSIGN_OR_RETURN(const int half, Half(x));
  LOOM_ASSIGN_OR_RETURN(const int quarter, Half(half));
  return quarter;
}

Status CheckEven(int x) {
  LOOM_RETURN_IF_ERROR(Half(x).status());
  return Status::Ok();
}

TEST(ResultTest, ValueAndErrorPropagate) {
  EXPECT_EQ(*Quarter(12), 3);
  const Result<int> failed = Quarter(6);
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.status().ToString(), "invalid argument: x: odd: 3");
  EXPECT_TRUE(CheckEven(4).ok());
  EXPECT_EQ(CheckEven(5).code(), StatusCode::kInvalidArgument);
}

TEST(ResultTest, ReadingAFailedResultIsABug) {
  const Result<int> failed = Half(3);
  EXPECT_THROW(static_cast<void>(failed.value()), CheckError);
  EXPECT_THROW(static_cast<void>(Result<int>(Status::Ok())), CheckError);
}

TEST(ResultTest, MoveOnlyValues) {
  Result<std::unique_ptr<int>> r(std::make_unique<int>(7));
  std::unique_ptr<int> p = std::move(r).value();
  EXPECT_EQ(*p, 7);
}

}  // namespace
}  // namespace loom
