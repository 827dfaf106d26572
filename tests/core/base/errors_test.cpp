// core/base/errors.h: codes, their names, and the exception classes that carry them.
#include "core/base/errors.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cctype>
#include <chrono>
#include <cstddef>
#include <set>
#include <string>

namespace geoprox {
namespace {

TEST(Errors, EveryCodeHasItsOwnCamelCaseName) {
  std::set<std::string> names;
  for (std::size_t c = 0; c < kErrorCodeCount; ++c) {
    const std::string& name = error_code_name(static_cast<ErrorCode>(c));
    ASSERT_FALSE(name.empty()) << "code " << c;
    EXPECT_TRUE(std::isupper(static_cast<unsigned char>(name[0]))) << name;
    for (const char ch : name) EXPECT_TRUE(std::isalnum(static_cast<unsigned char>(ch))) << name;
    EXPECT_TRUE(names.insert(name).second) << name << " names two codes";
  }
  EXPECT_EQ(error_code_name(ErrorCode::FaceOutOfRange), "FaceOutOfRange");
  EXPECT_EQ(error_code_name(ErrorCode::InternalError), "InternalError");
}

TEST(Errors, ExceptionsCarryTheirCodeAndMessage) {
  try {
    throw MeshError(ErrorCode::NonManifoldEdge, "edge 3 has three faces");
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::NonManifoldEdge);
    EXPECT_EQ(e.reason(), "NonManifoldEdge");
    EXPECT_STREQ(e.what(), "edge 3 has three faces");
  }
  EXPECT_EQ(ResourceExhausted("too many windows").code(), ErrorCode::ResourceExhausted);
  EXPECT_EQ(InternalError("x").code(), ErrorCode::InternalError);
}

TEST(Errors, AssertNamesTheConditionAndThrowsInternalError) {
  try {
    GEOPROX_ASSERT(1 + 1 == 3, "arithmetic");
    FAIL() << "no throw";
  } catch (const InternalError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("1 + 1 == 3"), std::string::npos) << message;
    EXPECT_NE(message.find("arithmetic"), std::string::npos) << message;
    EXPECT_EQ(e.code(), ErrorCode::InternalError);
  }
}

TEST(Errors, InterruptThrowsCancelledOrDeadlineExceeded) {
  std::atomic<bool> cancelled{true};
  QueryInterrupt by_flag;
  by_flag.cancelled = &cancelled;
  try {
    by_flag.check();
    FAIL() << "no throw";
  } catch (const Interrupted& e) {
    EXPECT_EQ(e.code(), ErrorCode::Cancelled);
  }
  QueryInterrupt by_deadline;
  by_deadline.deadline = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  try {
    by_deadline.check();
    FAIL() << "no throw";
  } catch (const Interrupted& e) {
    EXPECT_EQ(e.code(), ErrorCode::DeadlineExceeded);
  }
  QueryInterrupt none;
  EXPECT_NO_THROW(none.check());
}

}  // namespace
}  // namespace geoprox
