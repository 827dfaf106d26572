// Typed errors of geoprox core: one exception hierarchy, one enum of codes.
//
// Every error thrown for bad input derives from geoprox::Error and carries an ErrorCode and a
// concrete human-readable message. The code's CamelCase name (reason(): "FaceOutOfRange") is
// what the command-line tool prints; the server maps codes to protocol reasons with a switch
// (server/error_mapping.cpp). The exception class says who is at fault; the code says what.
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace geoprox {

// X(name): one entry per code; the enum and the name table are both made from this list.
#define GEOPROX_ERROR_CODES(X)                                                                  \
  /* Points given by a caller (InvalidInput). */                                                \
  X(VertexOutOfRange) X(EdgeOutOfRange) X(FaceOutOfRange) X(SampleOutOfRange)                   \
  X(IsolatedVertex) X(BadBarycentric) X(BadEdgeParameter) X(BadPoint) X(BadPointSyntax)         \
  X(BadPosition) X(TooFarFromSurface)                                                           \
  /* Options and arguments of an operation (InvalidInput). */                                   \
  X(BadOption) X(BadCount) X(BadRadius) X(BadDirection) X(BadDistanceCount) X(BadGoal)         \
  X(BadGraphSize) X(BadHalfedge) X(BadHaloRings) X(BadLeafSize) X(BadLength) X(BadOffset)       \
  X(BadSamples) X(BadTargetError) X(BadTolerance) X(BadUnfoldSteps) X(BadControlPoints)         \
  X(BadPath) X(EmptyPath) X(NoSources) X(TooManySamples) X(TooManyTargets)                      \
  X(RefinementTooLarge) X(BadRenderOptions) X(BadScene) X(BadPairsLine)                         \
  /* Riemannian metrics (InvalidInput, MeshError). */                                           \
  X(BadMetric) X(TriangleInequality) X(NotPositiveDefinite) X(TargetsForAnotherGeometry)        \
  /* Graphs given with a mesh (InvalidInput). */                                                \
  X(GraphMismatch) X(InvalidGraph) X(NoGraph) X(NoCoverTable) X(MissingGraph)                  \
  /* Unusable meshes (MeshError). */                                                            \
  X(EmptyMesh) X(NonFiniteCoordinate) X(NonManifoldEdge) X(NonManifoldVertex)                   \
  X(InconsistentOrientation) X(DegenerateFaceIndices) X(BadEdgeLength) X(TooLarge)              \
  /* Files (FileError). */                                                                      \
  X(FileNotFound) X(NotAFile) X(ReadError) X(ParseError) X(UnsupportedFormat) X(WriteError)     \
  X(WriteFailed) X(MeshMismatch) X(EmptyFile) X(Truncated) X(CorruptHeader) X(CorruptGraph)     \
  X(ChecksumMismatch) X(ForeignFile) X(UnsupportedVersion) X(WrongEndianness)                   \
  /* Outcomes of work. */                                                                       \
  X(Unreachable) X(ResourceExhausted) X(DeadlineExceeded) X(Cancelled) X(InternalError)

enum class ErrorCode : std::uint8_t {
#define GEOPROX_ERROR_CODE_ENUMERATOR(name) name,
  GEOPROX_ERROR_CODES(GEOPROX_ERROR_CODE_ENUMERATOR)
#undef GEOPROX_ERROR_CODE_ENUMERATOR
};

/// How many codes there are: ErrorCode values are 0 .. kErrorCodeCount - 1.
#define GEOPROX_ERROR_CODE_ONE(name) +1
inline constexpr std::size_t kErrorCodeCount = 0 GEOPROX_ERROR_CODES(GEOPROX_ERROR_CODE_ONE);
#undef GEOPROX_ERROR_CODE_ONE

/// The stable CamelCase name of a code, e.g. "FaceOutOfRange".
const std::string& error_code_name(ErrorCode code);

class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, const std::string& message) : std::runtime_error(message), code_(code) {}
  ErrorCode code() const noexcept { return code_; }
  /// The code's CamelCase name, e.g. "FaceOutOfRange".
  const std::string& reason() const { return error_code_name(code_); }

 private:
  ErrorCode code_;
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
/// stops with this rather than take the machine.
class ResourceExhausted : public Error {
 public:
  explicit ResourceExhausted(const std::string& message)
      : Error(ErrorCode::ResourceExhausted, message) {}
};

/// Work stopped before it finished: its deadline passed (DeadlineExceeded) or its caller gave
/// up (Cancelled), see QueryInterrupt.
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
      throw Interrupted(ErrorCode::Cancelled, "the request was cancelled");
    }
    if (deadline != std::chrono::steady_clock::time_point::max() &&
        std::chrono::steady_clock::now() > deadline) {
      throw Interrupted(ErrorCode::DeadlineExceeded, "the request ran past its deadline");
    }
  }
};

/// An internal invariant failed: a bug in geoprox, never the caller's fault.
class InternalError : public Error {
 public:
  explicit InternalError(const std::string& message) : Error(ErrorCode::InternalError, message) {}
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
