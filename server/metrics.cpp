#include "server/metrics.h"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace geoprox::server {

std::string_view transport_name(Transport transport) {
  return transport == Transport::Http ? "http" : "tcp";
}

Metrics::Metrics()
    : method_slots_(protocol::all_methods().size() + 1),
      outcome_slots_(protocol::error_reasons().size() + 1),
      requests_(kTransportCount * method_slots_ * outcome_slots_),
      latency_(kTransportCount * method_slots_) {}

void Metrics::record_request(Transport transport, std::optional<protocol::Method> method,
                             std::optional<protocol::ErrorReason> error, double seconds) {
  const std::size_t m = static_cast<std::size_t>(transport) * method_slots_ +
                        (method ? static_cast<std::size_t>(*method) : method_slots_ - 1);
  const std::size_t o = error ? static_cast<std::size_t>(*error) + 1 : 0;
  requests_[m * outcome_slots_ + o].fetch_add(1, std::memory_order_relaxed);
  Histogram& h = latency_[m];
  std::size_t b = 0;
  while (b < kBuckets.size() && seconds > kBuckets[b]) ++b;
  h.buckets[b].fetch_add(1, std::memory_order_relaxed);
  const double ns = std::max(0.0, seconds) * 1e9;
  h.sum_ns.fetch_add(static_cast<std::uint64_t>(ns), std::memory_order_relaxed);
  h.count.fetch_add(1, std::memory_order_relaxed);
}

std::uint64_t Metrics::requests_total() const {
  std::uint64_t total = 0;
  for (const auto& c : requests_) total += c.load(std::memory_order_relaxed);
  return total;
}

std::string prometheus_label(std::string_view value) {
  std::string out;
  out.reserve(value.size());
  for (char c : value) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '"') {
      out += "\\\"";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

namespace {

/// `transport="tcp",method="geodesic.distance"` for a slot of latency_ (transport x method).
std::string slot_labels(std::size_t slot, std::size_t method_slots) {
  const auto methods = protocol::all_methods();
  const std::size_t m = slot % method_slots;
  std::string out = "transport=\"";
  out += transport_name(static_cast<Transport>(slot / method_slots));
  out += "\",method=\"";
  out += m < methods.size() ? protocol::method_name(methods[m]) : std::string_view("invalid");
  out += '"';
  return out;
}

/// The shortest text that reads back as the same double ("0.00025", not 0.00025000000000000001).
std::string format_double(double value) {
  char buf[64];
  const auto [end, error] = std::to_chars(buf, buf + sizeof buf, value);
  return error == std::errc() ? std::string(buf, end) : std::string("NaN");
}

void gauge(std::string& out, const char* name, const char* help, const char* type,
           double value) {
  out += "# HELP ";
  out += name;
  out += ' ';
  out += help;
  out += "\n# TYPE ";
  out += name;
  out += ' ';
  out += type;
  out += '\n';
  out += name;
  out += ' ';
  out += format_double(value);
  out += '\n';
}

}  // namespace

void Metrics::render(std::string& out) const {
  const auto reasons = protocol::error_reasons();
  out += "# HELP geoprox_requests_total Requests answered, by transport, method and outcome (ok "
         "or the error reason).\n# TYPE geoprox_requests_total counter\n";
  for (std::size_t m = 0; m < latency_.size(); ++m) {
    for (std::size_t o = 0; o < outcome_slots_; ++o) {
      const std::uint64_t n = requests_[m * outcome_slots_ + o].load(std::memory_order_relaxed);
      if (n == 0) continue;
      const std::string outcome = o == 0 ? "ok" : std::string(reasons[o - 1].name);
      out += "geoprox_requests_total{" + slot_labels(m, method_slots_) + ",outcome=\"" +
             outcome + "\"} " + std::to_string(n) + "\n";
    }
  }
  out += "# HELP geoprox_request_duration_seconds Time from reading a request to queueing its "
         "reply, by transport and method.\n# TYPE geoprox_request_duration_seconds "
         "histogram\n";
  for (std::size_t m = 0; m < latency_.size(); ++m) {
    const Histogram& h = latency_[m];
    const std::uint64_t count = h.count.load(std::memory_order_relaxed);
    if (count == 0) continue;
    const std::string label = slot_labels(m, method_slots_);
    std::uint64_t cumulative = 0;
    for (std::size_t b = 0; b < kBucketCount; ++b) {
      cumulative += h.buckets[b].load(std::memory_order_relaxed);
      const std::string le = b < kBuckets.size() ? format_double(kBuckets[b]) : "+Inf";
      out += "geoprox_request_duration_seconds_bucket{" + label + ",le=\"" + le + "\"} " +
             std::to_string(cumulative) + "\n";
    }
    out += "geoprox_request_duration_seconds_sum{" + label + "} " +
           format_double(static_cast<double>(h.sum_ns.load(std::memory_order_relaxed)) * 1e-9) +
           "\n";
    out += "geoprox_request_duration_seconds_count{" + label + "} " + std::to_string(count) +
           "\n";
  }
  auto load = [](const auto& a) { return static_cast<double>(a.load(std::memory_order_relaxed)); };
  gauge(out, "geoprox_in_flight_requests", "Requests accepted and not yet answered.", "gauge",
        load(in_flight));
  gauge(out, "geoprox_queue_depth", "Requests waiting for a compute thread.", "gauge",
        load(queue_depth));
  gauge(out, "geoprox_connections", "Open client connections.", "gauge", load(connections));
  gauge(out, "geoprox_connections_total", "Client connections accepted.", "counter",
        load(connections_total));
  gauge(out, "geoprox_connections_refused_total",
        "Connections closed at once because max_connections was reached.", "counter",
        load(connections_refused));
  gauge(out, "geoprox_accept_errors_total", "Failed accepts (EMFILE and the like).", "counter",
        load(accept_errors));
  gauge(out, "geoprox_slow_reader_disconnects_total",
        "Connections closed because their replies exceeded max_write_buffer_bytes.", "counter",
        load(slow_reader_disconnects));
  gauge(out, "geoprox_read_timeouts_total", "Idle connections closed by read_timeout_ms.",
        "counter", load(read_timeouts));
  gauge(out, "geoprox_bytes_read_total", "Bytes read from clients.", "counter",
        load(bytes_read));
  gauge(out, "geoprox_bytes_written_total", "Bytes written to clients.", "counter",
        load(bytes_written));
  gauge(out, "geoprox_reloads_total", "Graph reloads that swapped in a new graph.", "counter",
        load(reloads_ok));
  gauge(out, "geoprox_reload_failures_total", "Graph reloads refused (the old graph stayed).",
        "counter", load(reloads_failed));
  gauge(out, "geoprox_split_halves_total",
        "Second halves of queries (a near pair's second exact solve) run by an idle compute "
        "thread.",
        "counter", load(split_halves));
}

}  // namespace geoprox::server
