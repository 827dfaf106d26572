// The open client connections of a server, TCP and HTTP (private to server/): shutdown reaches
// each of them through this set, and the connection gauges of the metrics follow it.
//
// Thread-safe: accepts add, connections remove themselves from their strands, the drain reads it.
#pragma once

#include <memory>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "server/metrics.h"

namespace geoprox::server {

/// A client connection of either transport, as shutdown sees it.
class Session {
 public:
  virtual ~Session() = default;
  /// Shutdown: close once the replies owed so far are written.
  virtual void drain_close() = 0;
  /// Shutdown deadline: cancel what is in flight and close now.
  virtual void force_close() = 0;
};

class ConnectionManager {
 public:
  explicit ConnectionManager(Metrics& metrics) : metrics_(metrics) {}

  /// Counts `connection` open (geoprox_connections, geoprox_connections_total).
  void add(const std::shared_ptr<Session>& connection);
  /// Called once by a connection when it closes.
  void remove(const Session* connection);
  /// Shutdown: each connection closes once the replies queued so far are written.
  void drain_close_all();
  /// Shutdown deadline: each connection cancels what is in flight and closes now.
  void force_close_all();

 private:
  std::vector<std::shared_ptr<Session>> snapshot();

  Metrics& metrics_;
  std::mutex mutex_;
  std::unordered_map<const Session*, std::weak_ptr<Session>> connections_;
};

}  // namespace geoprox::server
