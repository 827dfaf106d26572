// One client of the query port (private to server/): reads lines, frames and decodes them,
// answers the cheap methods inline and hands the others to the compute pool, and writes the
// replies in the order they finish (pipelining, up to max_inflight_per_connection at once). A
// batch array line is one unit of work: inline when all its calls are, else one pool task.
//
// Threads: every member is used on the connection's strand only, except the inbox of finished
// queries that compute threads fill (deliver()).
#pragma once

#include <utility>  // before Boost.Asio 1.74: its awaitable.hpp uses std::exchange

#include <boost/asio.hpp>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "protocol/framing.h"
#include "protocol/json_rpc.h"
#include "protocol/request.h"
#include "server/compute_pool.h"
#include "server/config.h"
#include "server/connection_manager.h"
#include "server/metrics.h"
#include "server/service.h"

namespace geoprox::server {

/// What a connection uses of its server; all of it outlives every connection.
struct ConnectionEnv {
  const Config& config;
  Service& service;
  Metrics& metrics;
  ComputePool& pool;
  const ServerState& state;
  ConnectionManager& manager;
};

class Connection : public Session, public std::enable_shared_from_this<Connection> {
 public:
  using Clock = std::chrono::steady_clock;

  Connection(const ConnectionEnv& env, boost::asio::ip::tcp::socket socket);

  /// Starts reading (on the connection's strand).
  void start();
  /// Shutdown: close once the replies queued so far are written.
  void drain_close() override;
  /// Shutdown deadline: cancel what is in flight and close now.
  void force_close() override;

 private:
  struct Active {
    std::shared_ptr<std::atomic<bool>> cancelled;
  };
  /// A query a compute thread finished, waiting for the strand to send its reply.
  struct Finished {
    std::uint64_t key;
    std::shared_ptr<protocol::Call> call;  ///< null for a batch array
    protocol::Method method;               ///< of `call`
    std::string mesh;
    Clock::time_point received;
    Answer answer;
    std::shared_ptr<protocol::BatchCall> batch;  ///< set for a batch array
  };

  const ServerLimits& limits() const { return env_.config.server_limits; }

  // Reading and dispatching.
  void do_read();
  void on_read(boost::system::error_code ec, std::size_t n);
  void process_frames();
  void handle_line(const std::string& line);
  void dispatch(protocol::Call call, Clock::time_point received);
  void submit_to_pool(protocol::Call call, protocol::Method method, Clock::time_point received);
  void dispatch_batch(protocol::BatchCall batch, Clock::time_point received);
  void submit_batch_to_pool(protocol::BatchCall batch, Clock::time_point received,
                            bool never_refused);
  /// One unit of work handed to the compute pool: in flight, cancellable by close().
  std::uint64_t begin_pool_work(std::shared_ptr<std::atomic<bool>> cancelled);
  void end_pool_work(std::uint64_t key);
  protocol::ProtocolError overloaded_error() const;
  void note_auth(const Answer& answer);

  // Completing: compute threads deliver, the strand completes.
  void deliver(Finished done);
  void complete();
  void finish_request(const protocol::Call& call, protocol::Method method,
                      const std::string& mesh, Clock::time_point received, Answer answer);
  void finish_batch(const protocol::BatchCall& batch, const std::string& mesh,
                    Clock::time_point received, Answer answer);
  void log_request(const protocol::RequestId* id, std::string_view method, std::string_view mesh,
                   Clock::time_point received, std::optional<protocol::ErrorReason> error,
                   std::string_view reply);

  // Writing and closing.
  void enqueue_write(std::string line);
  void do_write();
  void on_write(boost::system::error_code ec, std::size_t n, std::size_t bytes);
  void maybe_finish();
  void arm_timer();
  void close(const char* why);

  ConnectionEnv env_;
  boost::asio::ip::tcp::socket socket_;
  boost::asio::steady_timer timer_;
  protocol::LineFramer framer_;
  std::vector<char> buffer_;
  std::string peer_;
  bool reading_ = false;
  bool eof_ = false;
  bool closing_ = false;
  bool closed_ = false;
  bool writing_ = false;
  /// server.auth succeeded last, or the server has no query token.
  bool authenticated_;
  bool locked_out_ = false;  ///< too many failed server.auth: nothing more is read or answered
  unsigned auth_failures_ = 0;
  std::size_t inflight_ = 0;
  std::uint64_t next_key_ = 0;
  std::unordered_map<std::uint64_t, Active> active_;
  std::deque<std::string> queue_;
  std::size_t queued_bytes_ = 0;
  std::vector<std::string> in_write_;
  std::vector<boost::asio::const_buffer> buffers_;
  Clock::time_point last_activity_ = Clock::now();
  bool batching_writes_ = false;  ///< inside complete(): replies are written once at its end
  std::vector<Finished> completing_;
  // The only members compute threads touch (deliver()): queries finished, not yet completed.
  std::mutex finished_mutex_;
  std::vector<Finished> finished_;
  bool finished_posted_ = false;  ///< a complete() is posted and has not taken finished_ yet
};

}  // namespace geoprox::server
