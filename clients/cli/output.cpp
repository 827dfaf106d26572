// Output of the `geoprox` tool: standard output, or a file replaced atomically (no paper).
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "clients/cli/cli.h"
#include "core/base/errors.h"

namespace geoprox::cli {

void print_diagnostic(const std::string& label, const std::string& message) {
  std::string line = "geoprox: " + label + ": " + message;
  for (char& c : line) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  line += '\n';
  std::fflush(stdout);
  std::fputs(line.c_str(), stderr);
  std::fflush(stderr);
}

void write_output(const std::string& text, const std::string& out_path) {
  if (!out_path.empty()) {
    write_file_atomically(out_path, text);
    return;
  }
  if (std::fwrite(text.data(), 1, text.size(), stdout) != text.size() || std::fflush(stdout) != 0) {
    throw FileError(ErrorCode::WriteFailed,
                    std::string("cannot write to standard output: ") + std::strerror(errno));
  }
}

void write_result(const std::string& text, const std::string& out_path, bool out_given) {
  if (out_given) {
    write_file_atomically(out_path, text);
  } else {
    write_output(text, "");
  }
}

void write_file_atomically(const std::string& path, const std::string& text) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  if (path.empty() || !target.has_filename()) {
    throw FileError(ErrorCode::WriteFailed, "output path '" + path + "' does not name a file");
  }
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  // Appended rather than "." + name + ...: g++ 12 at -O2 and above reports a false -Wrestrict
  // on that (GCC bug 105651), which breaks Release builds with GEOPROX_WERROR.
  std::string temp_name = ".";
  temp_name += target.filename().string();
  temp_name += ".XXXXXX";
  const std::string pattern = (dir / temp_name).string();
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');

  const int fd = ::mkstemp(name.data());
  if (fd < 0) {
    throw FileError(ErrorCode::WriteFailed, "cannot write '" + path +
                                                "': cannot create a temporary file in '" +
                                                dir.string() + "': " + std::strerror(errno));
  }
  const std::string temporary(name.data());
  bool is_open = true;
  auto fail = [&](const std::string& step) {
    const int err = errno;
    if (is_open) ::close(fd);
    ::unlink(temporary.c_str());
    throw FileError(ErrorCode::WriteFailed,
                    "cannot write '" + path + "': " + step + ": " + std::strerror(err));
  };

  // mkstemp creates the file 0600; give it the mode a plain open() would have.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  if (::fchmod(fd, 0666 & ~mask) != 0) fail("chmod");

  const char* data = text.data();
  std::size_t left = text.size();
  while (left > 0) {
    const ssize_t written = ::write(fd, data, left);
    if (written < 0) {
      if (errno == EINTR) continue;
      fail("write");
    }
    data += written;
    left -= static_cast<std::size_t>(written);
  }
  if (::fsync(fd) != 0) fail("fsync");
  is_open = false;
  if (::close(fd) != 0) fail("close");
  if (std::rename(temporary.c_str(), path.c_str()) != 0) fail("rename");
}

/// Parses a point given to `option`; the error names the option.
SurfacePoint parse_point(const std::string& option, const std::string& text) {
  try {
    return parse_surface_point(text);
  } catch (const InvalidInput& e) {
    throw InvalidInput(e.code(), option + ": " + e.what());
  }
}

/// Checks a parsed point against the mesh; the error names the option and the text as given.
void validate_point(const std::string& option, const std::string& text, const SurfacePoint& point,
                    const TriangleMesh& mesh) {
  try {
    point.validate(mesh);
  } catch (const InvalidInput& e) {
    throw InvalidInput(e.code(), option + " " + text + ": " + e.what());
  }
}

/// CLI11 check for --radius: a number >= 0, `inf` allowed.
std::string check_radius(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || std::isnan(value) || value < 0) {
    return "must be a non-negative number or inf, not '" + text + "'";
  }
  return {};
}

/// %.17g, with infinity spelt `inf` whatever the C library does.
void append_number(std::string& out, double value) {
  GEOPROX_ASSERT(!std::isnan(value), "a distance or coordinate is NaN");
  if (std::isinf(value)) {
    out += value > 0 ? "inf" : "-inf";
    return;
  }
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", value);
  out += buf;
}

std::string join_words(const std::vector<std::string>& words) {
  std::string out;
  for (const std::string& word : words) out += (out.empty() ? "" : " ") + word;
  return out;
}

}  // namespace geoprox::cli
