// The web viewer's files (clients/web/dist), served by the HTTP listener at "/" (docs/http.md):
// read from one directory, never from outside it. Private to server/.
//
// Threads: const after construction, safe to call from any thread.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

#include "server/config.h"

namespace geoprox::server {

/// The directory of the viewer's built files that `config` names: `http_static_dir` when set
/// (empty: none), else the first of these holding an index.html: `../share/geoprox/web` next to
/// the running executable (the install layout: bin/geoproxd), then the source tree's
/// `clients/web/dist` (a build-tree geoproxd). Empty when none: no files served. Throws
/// ConfigError when `http_static_dir` is set to something that is not a directory.
std::filesystem::path static_dir_of(const Config& config);

/// One file to send.
struct StaticFile {
  std::string body;
  std::string_view content_type;
  std::string_view cache_control;
};

class StaticFiles {
 public:
  /// Serves the files under `root` (empty: none). Files larger than `max_file_bytes` are
  /// refused (TooLarge).
  StaticFiles(const std::filesystem::path& root, std::size_t max_file_bytes);

  bool enabled() const { return !root_.empty(); }
  /// The canonical directory served (empty when none).
  const std::filesystem::path& root() const { return root_; }

  /// The file a request path (without its query string) names. Throws ProtocolError:
  /// InvalidRequest for a path that could leave the directory (protocol::static_file_path),
  /// NotFound for no such regular file inside the directory (a symbolic link resolving outside
  /// it included) or when nothing is served, TooLarge beyond max_file_bytes.
  StaticFile read(std::string_view request_path) const;

 private:
  std::filesystem::path root_;
  std::size_t max_file_bytes_;
};

}  // namespace geoprox::server
