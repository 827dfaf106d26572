// Counters, gauges and latency histograms of geoproxd, rendered as Prometheus text (exposition
// format 0.0.4). Lock-free: every request updates a few relaxed atomics.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/errors.h"
#include "protocol/messages.h"

namespace geoprox::server {

/// How a request reached the server (the `transport` label of the request metrics).
enum class Transport : std::uint8_t { Tcp, Http };
std::string_view transport_name(Transport transport);  ///< "tcp", "http"

class Metrics {
 public:
  /// Histogram upper bounds (seconds); +Inf is implicit.
  static constexpr std::array<double, 16> kBuckets = {0.0001, 0.00025, 0.0005, 0.001, 0.0025,
                                                      0.005,  0.01,    0.025,  0.05,  0.1,
                                                      0.25,   0.5,     1,      2.5,   5,
                                                      10};

  Metrics();

  /// One answered (or refused) request: `method` is nullopt for lines that were not a request
  /// of a known method; `error` nullopt for a success.
  void record_request(Transport transport, std::optional<protocol::Method> method,
                      std::optional<protocol::ErrorReason> error, double seconds);

  /// Appends the request counters and histograms and every gauge below.
  void render(std::string& out) const;

  std::uint64_t requests_total() const;

  // Gauges and counters maintained by the transport.
  std::atomic<std::int64_t> in_flight{0};    ///< requests accepted and not yet answered
  std::atomic<std::int64_t> queue_depth{0};  ///< waiting for a compute thread
  std::atomic<std::int64_t> connections{0};
  std::atomic<std::uint64_t> connections_total{0};
  std::atomic<std::uint64_t> connections_refused{0};  ///< over max_connections
  std::atomic<std::uint64_t> accept_errors{0};
  std::atomic<std::uint64_t> slow_reader_disconnects{0};
  std::atomic<std::uint64_t> read_timeouts{0};
  std::atomic<std::uint64_t> bytes_read{0};
  std::atomic<std::uint64_t> bytes_written{0};
  std::atomic<std::uint64_t> reloads_ok{0};
  std::atomic<std::uint64_t> reloads_failed{0};
  /// Second halves of queries (a near pair's second exact solve) run by another compute thread.
  std::atomic<std::uint64_t> split_halves{0};

 private:
  static constexpr std::size_t kBucketCount = kBuckets.size() + 1;
  struct Histogram {
    std::array<std::atomic<std::uint64_t>, kBucketCount> buckets{};
    std::atomic<std::uint64_t> sum_ns{0};
    std::atomic<std::uint64_t> count{0};
  };
  static constexpr std::size_t kTransportCount = 2;
  std::size_t method_slots_;  // methods + 1 ("invalid"), per transport
  std::size_t outcome_slots_;  // reasons + 1 ("ok")
  std::vector<std::atomic<std::uint64_t>> requests_;  // transport x method x outcome
  std::vector<Histogram> latency_;                    // transport x method
};

/// Escapes a Prometheus label value (backslash, double quote, newline).
std::string prometheus_label(std::string_view value);

}  // namespace geoprox::server
