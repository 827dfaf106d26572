// Typed errors of geoprox (no paper: the project's one error header).
//
// Every error thrown for bad input derives from geoprox::Error and carries a stable CamelCase
// reason (FaceOutOfRange, BadBarycentric, NonManifold, ...) that the protocol layer forwards to
// clients as `data.reason`, plus a concrete human-readable message.
#pragma once

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>

namespace geoprox {

class Error : public std::runtime_error {
 public:
  Error(std::string reason, const std::string& message)
      : std::runtime_error(message), reason_(std::move(reason)) {}
  /// Stable CamelCase identifier of the failure, e.g. "FaceOutOfRange".
  const std::string& reason() const noexcept { return reason_; }

 private:
  std::string reason_;
};

/// A caller-supplied value is invalid (point ids, barycentrics, options, NaN).
class InvalidInput : public Error {
 public:
  using Error::Error;
};

/// A mesh is unusable: empty, non-finite coordinates, non-manifold, bad edge lengths.
class MeshError : public Error {
 public:
  using Error::Error;
};

/// A file cannot be read, parsed or written.
class FileError : public Error {
 public:
  using Error::Error;
};

/// Two points lie in different connected components (or beyond a solve's reach).
class Unreachable : public Error {
 public:
  using Error::Error;
};

/// Work would need more memory than its bound allows (a bound derived from the mesh's size): it
/// stops with this rather than take the machine. Reason "ResourceExhausted".
class ResourceExhausted : public Error {
 public:
  explicit ResourceExhausted(const std::string& message) : Error("ResourceExhausted", message) {}
};

/// Work stopped before it finished: its deadline passed ("DeadlineExceeded") or its caller gave
/// up ("Cancelled"), see QueryInterrupt.
class Interrupted : public Error {
 public:
  using Error::Error;
};

/// A deadline and/or a cancel flag that long-running work polls (every few hundred steps) and
/// answers by throwing Interrupted. Owned by the caller; read-only for the work.
struct QueryInterrupt {
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
  const std::atomic<bool>* cancelled = nullptr;

  /// Throws Interrupted if the deadline has passed or the flag is set.
  void check() const {
    if (cancelled && cancelled->load(std::memory_order_relaxed)) {
      throw Interrupted("Cancelled", "the request was cancelled");
    }
    if (deadline != std::chrono::steady_clock::time_point::max() &&
        std::chrono::steady_clock::now() > deadline) {
      throw Interrupted("DeadlineExceeded", "the request ran past its deadline");
    }
  }
};

/// An internal invariant failed: a bug in geoprox, never the caller's fault.
class InternalError : public Error {
 public:
  explicit InternalError(const std::string& message) : Error("InternalError", message) {}
};

[[noreturn]] void throw_internal_error(const char* condition, const char* file, int line,
                                       const std::string& detail);

}  // namespace geoprox

/// Checks an internal invariant; on failure throws InternalError naming file and line, so that a
/// server can turn it into an error reply instead of dying.
#define GEOPROX_ASSERT(condition, detail)                                        \
  do {                                                                           \
    if (!(condition)) {                                                          \
      ::geoprox::throw_internal_error(#condition, __FILE__, __LINE__, (detail)); \
    }                                                                            \
  } while (false)
