#include "server/connection_manager.h"

namespace geoprox::server {

void ConnectionManager::add(const std::shared_ptr<Session>& connection) {
  std::lock_guard lock(mutex_);
  connections_.emplace(connection.get(), connection);
  metrics_.connections.fetch_add(1);
  metrics_.connections_total.fetch_add(1);
}

void ConnectionManager::remove(const Session* connection) {
  std::lock_guard lock(mutex_);
  if (connections_.erase(connection)) metrics_.connections.fetch_sub(1);
}

std::vector<std::shared_ptr<Session>> ConnectionManager::snapshot() {
  std::lock_guard lock(mutex_);
  std::vector<std::shared_ptr<Session>> out;
  for (auto& [raw, weak] : connections_) {
    if (auto connection = weak.lock()) out.push_back(std::move(connection));
  }
  return out;
}

void ConnectionManager::drain_close_all() {
  for (auto& connection : snapshot()) connection->drain_close();
}

void ConnectionManager::force_close_all() {
  for (auto& connection : snapshot()) connection->force_close();
}

}  // namespace geoprox::server
