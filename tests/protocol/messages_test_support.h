// Helpers shared by the tests of protocol/messages (messages_test.cpp,
// messages_applications_test.cpp). Header-only.
#pragma once

#include <gtest/gtest.h>

#include <string>
#include <string_view>

#include "protocol/errors.h"
#include "protocol/messages.h"

namespace geoprox::protocol::test_support {

/// parse_params refuses `params` of `method` with `reason`, in a message containing `fragment`.
inline void expect_refused(Method method, const nlohmann::json& params, ErrorReason reason,
                           std::string_view fragment, const Limits& limits = {}) {
  // The params can be large (limit tests): only their start goes into the trace.
  SCOPED_TRACE(std::string(method_name(method)) + " " + params.dump().substr(0, 300));
  try {
    parse_params(method, params, limits);
    ADD_FAILURE() << "accepted";
  } catch (const ProtocolError& error) {
    EXPECT_EQ(error.reason(), reason) << error.what();
    EXPECT_NE(std::string(error.what()).find(fragment), std::string::npos)
        << "message '" << error.what() << "' lacks '" << fragment << "'";
  }
}

}  // namespace geoprox::protocol::test_support
