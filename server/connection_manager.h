// The open query connections of a server (private to server/): shutdown reaches each of them
// through this set, and the connection gauges of the metrics follow it.
//
// Thread-safe: accepts add, connections remove themselves from their strands, the drain reads it.
#pragma once

#include <memory>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "server/metrics.h"

namespace geoprox::server {

class Connection;

class ConnectionManager {
 public:
  explicit ConnectionManager(Metrics& metrics) : metrics_(metrics) {}

  /// Counts `connection` open (geoprox_connections, geoprox_connections_total).
  void add(const std::shared_ptr<Connection>& connection);
  /// Called once by a connection when it closes.
  void remove(const Connection* connection);
  /// Shutdown: each connection closes once the replies queued so far are written.
  void drain_close_all();
  /// Shutdown deadline: each connection cancels what is in flight and closes now.
  void force_close_all();

 private:
  std::vector<std::shared_ptr<Connection>> snapshot();

  Metrics& metrics_;
  std::mutex mutex_;
  std::unordered_map<const Connection*, std::weak_ptr<Connection>> connections_;
};

}  // namespace geoprox::server
