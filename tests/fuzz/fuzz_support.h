// Shared by the fuzzers: the mesh loaders and the graph-file opener take a path (they read the
// file whole, or map it), and neither has an in-memory entry, so each input is written to a file
// in a private directory, on tmpfs (/dev/shm) when there is one, and rewritten for every input.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace geoprox::fuzz {

class ScratchDirectory {
 public:
  ScratchDirectory() {
    const std::filesystem::path base =
        std::filesystem::is_directory("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
    std::string pattern = (base / "geoprox-fuzz-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      std::perror("geoprox fuzz: mkdtemp");
      std::abort();
    }
    directory_ = pattern;
  }
  ~ScratchDirectory() {
    std::error_code ignored;
    std::filesystem::remove_all(directory_, ignored);
  }
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;

  /// Writes `data` to `name` in the directory (replacing it) and returns the file's path.
  std::string write(const std::string& name, const std::uint8_t* data, std::size_t size) const {
    const std::string path = directory_ + "/" + name;
    std::FILE* file = std::fopen(path.c_str(), "wb");
    if (file == nullptr || (size > 0 && std::fwrite(data, 1, size, file) != size) ||
        std::fclose(file) != 0) {
      // A harness failure, not a finding in the code under test: stop loudly.
      std::perror(("geoprox fuzz: cannot write " + path).c_str());
      std::abort();
    }
    return path;
  }

 private:
  std::string directory_;
};

/// Aborts (a libFuzzer finding) with a message when a promised invariant does not hold.
#define GEOPROX_FUZZ_CHECK(condition, message)                                            \
  do {                                                                                    \
    if (!(condition)) {                                                                   \
      std::fprintf(stderr, "%s:%d: fuzz invariant failed: %s (%s)\n", __FILE__, __LINE__, \
                   #condition, std::string(message).c_str());                             \
      std::abort();                                                                       \
    }                                                                                     \
  } while (false)

}  // namespace geoprox::fuzz
