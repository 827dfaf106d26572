// Error reasons of the geoprox protocol: the one table of reason -> JSON-RPC code -> retryability.
//
// Every error reply carries `error.code` (a JSON-RPC 2.0 code), a concrete `error.message` that
// names the offending field, and `error.data = {"reason": CamelCase, "retryable": bool}` (plus
// `retry_after_ms` when the server suggests a delay). Reasons are stable identifiers that clients
// switch on; codes are what generic JSON-RPC clients understand. Each reason has exactly one
// code; several reasons share -32602 (invalid params) because the issue asks that every bad point
// be reported as invalid params. docs/protocol.md lists the same table (a test keeps them equal).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>

namespace geoprox::protocol {

/// JSON-RPC 2.0 codes. -32000..-32099 is the range the specification reserves for servers.
namespace error_code {
inline constexpr int kParseError = -32700;
inline constexpr int kInvalidRequest = -32600;
inline constexpr int kMethodNotFound = -32601;
inline constexpr int kInvalidParams = -32602;
inline constexpr int kInternalError = -32603;
inline constexpr int kUnknownMesh = -32001;
inline constexpr int kMeshNotReady = -32002;
inline constexpr int kMeshBuildFailed = -32003;
inline constexpr int kMeshExists = -32004;
inline constexpr int kBadMeshFile = -32005;
inline constexpr int kNotFound = -32006;
inline constexpr int kUnreachable = -32010;
inline constexpr int kTooLarge = -32020;
inline constexpr int kResourceExhausted = -32021;
inline constexpr int kOverloaded = -32030;
inline constexpr int kDeadlineExceeded = -32031;
inline constexpr int kShuttingDown = -32032;
inline constexpr int kUnauthorized = -32040;
}  // namespace error_code

enum class ErrorReason : std::uint8_t {
  // Envelope (protocol/json_rpc.h).
  ParseError,
  InvalidRequest,
  UnknownMethod,
  // Parameters (protocol/messages.h, protocol/points.h); range checks are the server's.
  InvalidParams,
  BadPoint,
  BadBarycentric,
  BadEdgeParameter,
  VertexOutOfRange,
  EdgeOutOfRange,
  FaceOutOfRange,
  SampleOutOfRange,
  IsolatedVertex,
  PathNotAllowed,
  // Meshes and the registry (server).
  UnknownMesh,
  MeshNotReady,
  MeshBuildFailed,
  MeshExists,
  BadMeshFile,
  NotFound,
  // Answers and resources (server).
  Unreachable,
  TooLarge,
  ResourceExhausted,
  Overloaded,
  DeadlineExceeded,
  ShuttingDown,
  Unauthorized,
  Internal,
};

struct ErrorReasonInfo {
  ErrorReason reason;
  std::string_view name;  ///< the wire string in `data.reason`
  int code;               ///< JSON-RPC `error.code`
  bool retryable;         ///< the same request may succeed later unchanged
  std::string_view meaning;
};

/// Every reason, in declaration order.
std::span<const ErrorReasonInfo> error_reasons();
const ErrorReasonInfo& describe(ErrorReason reason);
inline std::string_view reason_name(ErrorReason reason) { return describe(reason).name; }
inline int error_code_of(ErrorReason reason) { return describe(reason).code; }
inline bool is_retryable(ErrorReason reason) { return describe(reason).retryable; }
/// The reason whose wire name is `name` (exact, case-sensitive), if any. Clients use it to turn
/// `data.reason` back into the enum. Careful when mapping core errors (geoprox::Error::reason()):
/// core's "ParseError" is a mesh-file parse error (BadMeshFile here), not a JSON one.
std::optional<ErrorReason> reason_from_name(std::string_view name);

/// The error every protocol function throws for bad input, and what the server throws (or builds)
/// for its own failures: reason + concrete message, serialized by protocol/json_rpc.h.
class ProtocolError : public std::runtime_error {
 public:
  ProtocolError(ErrorReason reason, const std::string& message)
      : std::runtime_error(message), reason_(reason) {}

  ErrorReason reason() const noexcept { return reason_; }
  std::string_view reason_name() const { return protocol::reason_name(reason_); }
  int code() const { return error_code_of(reason_); }
  bool retryable() const { return is_retryable(reason_); }

  /// A hint for retryable errors (Overloaded, MeshNotReady): wait this long before retrying.
  std::optional<std::int64_t> retry_after_ms() const noexcept { return retry_after_ms_; }
  ProtocolError& set_retry_after_ms(std::int64_t milliseconds) {
    retry_after_ms_ = milliseconds;
    return *this;
  }

 private:
  ErrorReason reason_;
  std::optional<std::int64_t> retry_after_ms_;
};

}  // namespace geoprox::protocol
