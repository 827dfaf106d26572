#include "server/static_files.h"

#include <algorithm>
#include <cstdint>
#include <fstream>
#include <system_error>

#include "protocol/errors.h"
#include "protocol/http_api.h"

namespace geoprox::server {

namespace fs = std::filesystem;
using protocol::ErrorReason;
using protocol::ProtocolError;

namespace {

bool has_index(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(dir / "index.html", ec);
}

/// The running executable's directory (empty when unknown).
fs::path executable_dir() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe.parent_path();
}

}  // namespace

fs::path static_dir_of(const Config& config) {
  if (config.http_static_dir) {
    const fs::path& dir = *config.http_static_dir;
    if (dir.empty()) return {};
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) {
      throw ConfigError("http_static_dir: " + dir.string() + " is not a directory");
    }
    return dir;
  }
  if (const fs::path exe_dir = executable_dir(); !exe_dir.empty()) {
    const fs::path installed = exe_dir / ".." / "share" / "geoprox" / "web";
    if (has_index(installed)) return installed;
  }
#ifdef GEOPROX_SOURCE_WEB_DIST
  if (has_index(GEOPROX_SOURCE_WEB_DIST)) return GEOPROX_SOURCE_WEB_DIST;
#endif
  return {};
}

StaticFiles::StaticFiles(const fs::path& root, std::size_t max_file_bytes)
    : max_file_bytes_(max_file_bytes) {
  if (!root.empty()) root_ = fs::canonical(root);
}

StaticFile StaticFiles::read(std::string_view request_path) const {
  const std::string relative = protocol::static_file_path(request_path);
  const auto not_found = [&] {
    return ProtocolError(ErrorReason::NotFound,
                         "no file at \"" + std::string(request_path.substr(0, 80)) + "\"" +
                             (enabled() ? "" : " (this server serves no web viewer)"));
  };
  if (!enabled()) throw not_found();
  // Symbolic links are followed, and the file they lead to must be inside the directory.
  std::error_code ec;
  const fs::path file = fs::canonical(root_ / relative, ec);
  if (ec) throw not_found();
  const auto [root_end, file_it] =
      std::mismatch(root_.begin(), root_.end(), file.begin(), file.end());
  if (root_end != root_.end() || file_it == file.end() || !fs::is_regular_file(file, ec)) {
    throw not_found();
  }
  const auto too_large = [&] {
    return ProtocolError(ErrorReason::TooLarge,
                         "the file \"" + relative + "\" is larger than max_output_bytes (" +
                             std::to_string(max_file_bytes_) + ")");
  };
  const std::uintmax_t size = fs::file_size(file, ec);
  if (ec) throw not_found();
  if (size > max_file_bytes_) throw too_large();
  std::ifstream in(file, std::ios::binary);
  if (!in) throw not_found();
  StaticFile out;
  // One byte beyond its size: a file that grew past the cap since is still refused.
  out.body.resize(static_cast<std::size_t>(size) + 1);
  in.read(out.body.data(), static_cast<std::streamsize>(out.body.size()));
  out.body.resize(static_cast<std::size_t>(in.gcount()));
  if (out.body.size() > max_file_bytes_) throw too_large();
  out.content_type = protocol::static_content_type(relative);
  out.cache_control = protocol::static_cache_control(relative);
  return out;
}

}  // namespace geoprox::server
