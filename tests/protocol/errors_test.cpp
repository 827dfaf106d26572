// The reason table: one code per reason, codes in the right JSON-RPC ranges, retryability.
#include "protocol/errors.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

namespace geoprox::protocol {
namespace {

TEST(ErrorReasons, TableCoversEveryReasonOnceWithUniqueNames) {
  std::set<std::string_view> names;
  std::size_t index = 0;
  for (const ErrorReasonInfo& info : error_reasons()) {
    EXPECT_EQ(static_cast<std::size_t>(info.reason), index++);
    EXPECT_TRUE(names.insert(info.name).second) << "duplicate name " << info.name;
    EXPECT_FALSE(info.meaning.empty()) << info.name;
    // CamelCase: starts upper-case, letters only.
    EXPECT_TRUE(info.name[0] >= 'A' && info.name[0] <= 'Z') << info.name;
    EXPECT_EQ(info.name.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz"),
              std::string_view::npos)
        << info.name;
    EXPECT_EQ(reason_from_name(info.name), info.reason);
    EXPECT_EQ(&describe(info.reason), &info);
  }
  EXPECT_EQ(index, static_cast<std::size_t>(ErrorReason::Internal) + 1);
  EXPECT_FALSE(reason_from_name("internal"));
  EXPECT_FALSE(reason_from_name(""));
}

TEST(ErrorReasons, JsonRpcCodesOfTheEnvelopeReasons) {
  EXPECT_EQ(error_code_of(ErrorReason::ParseError), -32700);
  EXPECT_EQ(error_code_of(ErrorReason::InvalidRequest), -32600);
  EXPECT_EQ(error_code_of(ErrorReason::UnknownMethod), -32601);
  EXPECT_EQ(error_code_of(ErrorReason::InvalidParams), -32602);
  EXPECT_EQ(error_code_of(ErrorReason::Internal), -32603);
}

TEST(ErrorReasons, BadPointsAreInvalidParams) {
  for (ErrorReason reason :
       {ErrorReason::BadPoint, ErrorReason::BadBarycentric, ErrorReason::BadEdgeParameter,
        ErrorReason::VertexOutOfRange, ErrorReason::EdgeOutOfRange, ErrorReason::FaceOutOfRange,
        ErrorReason::SampleOutOfRange, ErrorReason::IsolatedVertex, ErrorReason::PathNotAllowed}) {
    EXPECT_EQ(error_code_of(reason), -32602) << reason_name(reason);
  }
}

TEST(ErrorReasons, ServerReasonsUseDistinctCodesOfTheServerRange) {
  std::set<int> codes;
  for (const ErrorReasonInfo& info : error_reasons()) {
    if (info.code >= -32099 && info.code <= -32000) {
      EXPECT_TRUE(codes.insert(info.code).second) << "shared server code " << info.code;
    } else {
      EXPECT_TRUE(info.code == -32700 || (info.code <= -32600 && info.code >= -32603))
          << info.name << " " << info.code;
    }
  }
  EXPECT_EQ(error_code_of(ErrorReason::UnknownMesh), -32001);
  EXPECT_EQ(error_code_of(ErrorReason::MeshNotReady), -32002);
  EXPECT_EQ(error_code_of(ErrorReason::Unreachable), -32010);
  EXPECT_EQ(error_code_of(ErrorReason::TooLarge), -32020);
  EXPECT_EQ(error_code_of(ErrorReason::ResourceExhausted), -32021);
  EXPECT_EQ(error_code_of(ErrorReason::Overloaded), -32030);
  EXPECT_EQ(error_code_of(ErrorReason::DeadlineExceeded), -32031);
  EXPECT_EQ(error_code_of(ErrorReason::Unauthorized), -32040);
}

TEST(ErrorReasons, RetryableOnlyWhereTheSameRequestCanSucceedLater) {
  std::set<std::string_view> retryable;
  for (const ErrorReasonInfo& info : error_reasons()) {
    if (info.retryable) retryable.insert(info.name);
  }
  EXPECT_EQ(retryable, (std::set<std::string_view>{"MeshNotReady", "Overloaded", "DeadlineExceeded",
                                                   "ShuttingDown", "Internal"}));
}

TEST(ProtocolError, CarriesReasonCodeMessageAndRetryHint) {
  ProtocolError error(ErrorReason::Overloaded, "compute queue full (64 waiting)");
  EXPECT_EQ(error.reason(), ErrorReason::Overloaded);
  EXPECT_EQ(error.reason_name(), "Overloaded");
  EXPECT_EQ(error.code(), -32030);
  EXPECT_TRUE(error.retryable());
  EXPECT_STREQ(error.what(), "compute queue full (64 waiting)");
  EXPECT_FALSE(error.retry_after_ms());
  error.set_retry_after_ms(25);
  EXPECT_EQ(error.retry_after_ms(), 25);
}

}  // namespace
}  // namespace geoprox::protocol
