// What geoproxd answers, independent of sockets: one decoded Call in, one reply line out.
//
// answer() is the request boundary: every failure below it (a protocol error, a core error, a
// bad_alloc, a bug) is turned into an error reply by its one catch, never thrown to the caller.
// Core errors map to protocol reasons: point reasons (FaceOutOfRange, BadBarycentric, ...) keep
// their name as -32602 errors, positions that cannot be snapped are BadPoint, other InvalidInput
// reasons are InvalidParams with the core message, Unreachable is Unreachable, Interrupted is
// DeadlineExceeded (or ShuttingDown when the server cancelled it while draining), anything else
// is Internal.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/base/errors.h"
#include "protocol/errors.h"
#include "protocol/request.h"
#include "server/config.h"
#include "server/metrics.h"
#include "server/registry.h"

namespace geoprox::server {

/// Process-wide state the health and metrics answers read.
struct ServerState {
  std::atomic<bool> draining{false};
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
};

/// One request's deadline and cancel flag, and what the logs want to know about it.
struct RequestContext {
  QueryInterrupt interrupt;
  std::string mesh;  ///< the mesh it ran on, once known
};

struct Answer {
  std::string line;  ///< the reply line with "\n"; empty for a notification
  std::optional<protocol::ErrorReason> error;
};

/// A call's outcome before it is framed as a reply line: what the HTTP resource paths send.
/// Exactly one of error, field, matrix and result holds the answer.
struct Outcome {
  std::optional<protocol::ProtocolError> error;
  std::optional<protocol::FieldResult> field;    ///< geodesic.field, its arrays as computed
  std::optional<protocol::MatrixResult> matrix;  ///< geodesic.matrix
  nlohmann::json result;                         ///< any other method
};

/// Vertex positions (x, y, z per vertex) and triangles (3 vertex ids each) of a mesh in service.
struct MeshGeometry {
  std::string mesh;
  std::string mesh_version;
  std::vector<double> positions;
  std::vector<std::uint32_t> triangles;
};

class Service {
 public:
  Service(const Config& config, Registry& registry, Metrics& metrics, ServerState& state);

  /// Methods cheap enough to answer on the I/O thread (no geometry work, no file access).
  static bool answered_inline(protocol::Method method);

  /// Failed server.auth calls after which the server closes the connection (slows guessing).
  static constexpr unsigned kMaxAuthFailures = 5;
  /// The server has a query token: connections must call server.auth before other methods.
  bool query_token_required() const { return !config_.query_token.empty(); }
  /// Whether `token` is the query token (constant time; true when there is none). answer()
  /// of a server.auth call says the same: a result, or the error Unauthorized.
  bool query_token_matches(std::string_view token) const;

  /// The reply to `call` (never throws).
  Answer answer(const protocol::Call& call, RequestContext& context) const noexcept;
  /// The outcome of `call`, not framed (never throws). answer() frames it.
  Outcome evaluate(const protocol::Call& call, RequestContext& context) const noexcept;
  /// The geometry of mesh `id` as served (the mesh as given, not a refinement inside its
  /// graph). Throws ProtocolError (UnknownMesh, MeshNotReady, ...) like the queries.
  MeshGeometry geometry(const std::string& id, RequestContext& context) const;
  /// The reply to a call that could not be run (Overloaded, ShuttingDown...).
  static Answer refuse(const protocol::Call& call, const protocol::ProtocolError& error);

  /// Prometheus text: request metrics plus mesh states and build progress.
  std::string metrics_text() const;
  protocol::HealthResult health() const;
  bool ready() const;
  /// The body of /readyz ("ready\n", "not ready: starting\n" or "not ready: draining\n")
  /// and whether it is ready (200, else 503).
  std::pair<bool, std::string> readiness() const;
  /// Reopens graph files (admin.reload, SIGHUP), counting the outcomes in the metrics.
  std::vector<protocol::ReloadOutcome> reload(const std::optional<std::string>& mesh) const;

  // JSON-RPC 2.0 batch arrays (protocol::decode_message): one reply line for the whole array.

  /// The reply to a batch array: each element answered in order on the calling thread, under
  /// `context`'s deadline and cancel flag (each element's own timeout_ms may shorten it);
  /// elements other than server.health and server.auth are refused Unauthorized when
  /// `authenticated` is false. server.auth is refused InvalidRequest: it must be sent alone, as
  /// its effect on the connection would be ambiguous in an array. Each element is recorded in
  /// the metrics as its own request; replies beyond max_output_bytes (all together) become
  /// TooLarge errors. Answer::line is the array line, or empty when nothing is owed;
  /// Answer::error is Internal if an element failed so, else the first failure, if any.
  /// `transport` labels the metrics.
  Answer answer_batch(const protocol::BatchCall& batch, RequestContext& context,
                      bool authenticated, Transport transport) const noexcept;
  /// The reply to a batch array that could not be run (Overloaded, ShuttingDown): `error` for
  /// each call, except that calls refused before server.auth (see answer_batch) are
  /// Unauthorized and elements that are no valid request keep their own error. Recorded in the
  /// metrics like answer_batch().
  Answer refuse_batch(const protocol::BatchCall& batch, const protocol::ProtocolError& error,
                      bool authenticated, Transport transport) const noexcept;
  /// The refusal of `method` on a connection that has not passed server.auth.
  static protocol::ProtocolError unauthenticated_error(protocol::Method method);

 private:
  nlohmann::json execute(const protocol::Params& params, RequestContext& context) const;
  nlohmann::json batch(const protocol::BatchParams& params, RequestContext& context) const;
  /// The context of one element of a batch: the batch's interrupt, its deadline shortened by
  /// the element's own timeout_ms when that ends first.
  RequestContext element_context(const RequestContext& outer,
                                 std::optional<std::int64_t> timeout_ms) const;
  nlohmann::json mesh_info(const protocol::MeshInfoParams& params, RequestContext& context) const;
  void check_admin_token(const std::string& token) const;

  const Config& config_;
  Registry& registry_;
  Metrics& metrics_;
  ServerState& state_;
};

/// The protocol error for the exception being handled (call inside a catch block only).
protocol::ProtocolError current_error(bool draining);

/// Equal-length-independent, data-independent comparison of secrets.
bool constant_time_equal(std::string_view a, std::string_view b);

}  // namespace geoprox::server
