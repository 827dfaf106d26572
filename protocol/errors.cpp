#include "protocol/errors.h"

#include <array>

namespace geoprox::protocol {

namespace {

using R = ErrorReason;
namespace c = error_code;

// In declaration order of ErrorReason: describe() indexes this table by the enum value (checked
// at compile time below).
constexpr std::array kReasons = {
    ErrorReasonInfo{R::ParseError, "ParseError", c::kParseError, false,
                    "the line is not valid JSON or not valid UTF-8 (numbers beyond the range of a "
                    "double included)"},
    ErrorReasonInfo{R::InvalidRequest, "InvalidRequest", c::kInvalidRequest, false,
                    "valid JSON but not a JSON-RPC 2.0 request object (wrong jsonrpc, method, "
                    "params or id member; an empty batch array)"},
    ErrorReasonInfo{R::UnknownMethod, "UnknownMethod", c::kMethodNotFound, false,
                    "no method of that name"},
    ErrorReasonInfo{R::InvalidParams, "InvalidParams", c::kInvalidParams, false,
                    "a parameter is missing, of the wrong type, out of its range, or unknown"},
    ErrorReasonInfo{R::BadPoint, "BadPoint", c::kInvalidParams, false,
                    "a point is malformed: not one of the point forms, wrong types, a negative "
                    "or fractional id, a non-finite position"},
    ErrorReasonInfo{R::BadBarycentric, "BadBarycentric", c::kInvalidParams, false,
                    "face barycentrics not finite, negative beyond 1e-12, or not summing to 1 "
                    "within 1e-5"},
    ErrorReasonInfo{R::BadEdgeParameter, "BadEdgeParameter", c::kInvalidParams, false,
                    "edge parameter t not a finite number in [0, 1]"},
    ErrorReasonInfo{R::VertexOutOfRange, "VertexOutOfRange", c::kInvalidParams, false,
                    "vertex id not below the mesh's vertex count"},
    ErrorReasonInfo{R::EdgeOutOfRange, "EdgeOutOfRange", c::kInvalidParams, false,
                    "edge id not below the mesh's edge count"},
    ErrorReasonInfo{R::FaceOutOfRange, "FaceOutOfRange", c::kInvalidParams, false,
                    "face id not below the mesh's face count"},
    ErrorReasonInfo{R::SampleOutOfRange, "SampleOutOfRange", c::kInvalidParams, false,
                    "sample id not below the graph's sample count"},
    ErrorReasonInfo{R::IsolatedVertex, "IsolatedVertex", c::kInvalidParams, false,
                    "the vertex belongs to no face, so no geodesic reaches it"},
    ErrorReasonInfo{R::PathNotAllowed, "PathNotAllowed", c::kInvalidParams, false,
                    "an admin file path is empty, contains '..', a NUL or a backslash, or leaves "
                    "the data directory"},
    ErrorReasonInfo{R::UnknownMesh, "UnknownMesh", c::kUnknownMesh, false,
                    "no mesh registered under that id"},
    ErrorReasonInfo{R::MeshNotReady, "MeshNotReady", c::kMeshNotReady, true,
                    "the mesh's graph is still being built or loaded; retry later (see "
                    "mesh.list for progress)"},
    ErrorReasonInfo{R::MeshBuildFailed, "MeshBuildFailed", c::kMeshBuildFailed, false,
                    "the mesh's graph failed to build or load; mesh.list has the error"},
    ErrorReasonInfo{R::MeshExists, "MeshExists", c::kMeshExists, false,
                    "admin.register: a mesh with that id is already registered"},
    ErrorReasonInfo{R::BadMeshFile, "BadMeshFile", c::kBadMeshFile, false,
                    "a mesh or graph file named by an admin call cannot be read, is invalid, or "
                    "does not match its mesh"},
    ErrorReasonInfo{R::NotFound, "NotFound", c::kNotFound, false,
                    "a file named by an admin call does not exist"},
    ErrorReasonInfo{R::Unreachable, "Unreachable", c::kUnreachable, false,
                    "no geodesic joins the points (different components, or beyond the cutoff)"},
    ErrorReasonInfo{R::TooLarge, "TooLarge", c::kTooLarge, false,
                    "a limit was exceeded: line bytes, nesting depth, points, matrix pairs, "
                    "field sources, batch size or output bytes"},
    ErrorReasonInfo{R::ResourceExhausted, "ResourceExhausted", c::kResourceExhausted, false,
                    "answering would take more memory than the server allows one request (a "
                    "bound set by the mesh's size); the server goes on serving"},
    ErrorReasonInfo{R::Overloaded, "Overloaded", c::kOverloaded, true,
                    "the compute queue is full; retry after data.retry_after_ms"},
    ErrorReasonInfo{R::DeadlineExceeded, "DeadlineExceeded", c::kDeadlineExceeded, true,
                    "the request's timeout_ms (clamped to the server maximum) expired"},
    ErrorReasonInfo{R::ShuttingDown, "ShuttingDown", c::kShuttingDown, true,
                    "the server is draining for shutdown; retry on another instance"},
    ErrorReasonInfo{R::Unauthorized, "Unauthorized", c::kUnauthorized, false,
                    "a query before server.auth on a server with a query token, a wrong "
                    "server.auth token, or an admin method without the right admin token (or "
                    "admin methods disabled)"},
    ErrorReasonInfo{R::Internal, "Internal", c::kInternalError, true,
                    "a bug or an unexpected failure in the server; the message says what"},
};

constexpr bool table_follows_enum_order() {
  for (std::size_t i = 0; i < kReasons.size(); ++i) {
    if (static_cast<std::size_t>(kReasons[i].reason) != i) return false;
  }
  return static_cast<std::size_t>(ErrorReason::Internal) + 1 == kReasons.size();
}
static_assert(table_follows_enum_order(), "kReasons must list every ErrorReason in enum order");

}  // namespace

std::span<const ErrorReasonInfo> error_reasons() { return kReasons; }

const ErrorReasonInfo& describe(ErrorReason reason) {
  const auto index = static_cast<std::size_t>(reason);
  // An enum value outside the declared ones can only come from a bad cast; answer Internal
  // rather than read past the table.
  return index < kReasons.size() ? kReasons[index] : kReasons.back();
}

std::optional<ErrorReason> reason_from_name(std::string_view name) {
  for (const ErrorReasonInfo& info : kReasons) {
    if (info.name == name) return info.reason;
  }
  return std::nullopt;
}

}  // namespace geoprox::protocol
