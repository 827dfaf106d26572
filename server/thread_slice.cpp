#include "server/thread_slice.h"

#include <cerrno>
#include <cstdint>
#include <cstring>

#if defined(__linux__)
#include <sched.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

namespace geoprox::server {

#if defined(__linux__) && defined(SYS_sched_setattr)

namespace {

// The kernel's struct sched_attr (include/uapi/linux/sched/types.h, SCHED_ATTR_SIZE_VER1):
// glibc has no wrapper for sched_setattr.
struct SchedAttr {
  std::uint32_t size;
  std::uint32_t sched_policy;
  std::uint64_t sched_flags;
  std::int32_t sched_nice;
  std::uint32_t sched_priority;
  std::uint64_t sched_runtime;  // ns; under SCHED_OTHER, the slice asked for
  std::uint64_t sched_deadline;
  std::uint64_t sched_period;
  std::uint32_t sched_util_min;
  std::uint32_t sched_util_max;
};

std::string failed(const char* call) { return std::string(call) + ": " + std::strerror(errno); }

}  // namespace

std::optional<std::string> request_thread_slice(std::chrono::microseconds slice) {
  const pid_t thread = gettid();
  const int policy = sched_getscheduler(thread);
  if (policy < 0) return failed("sched_getscheduler");
  // A thread put under SCHED_BATCH, SCHED_IDLE or a real-time policy (chrt) keeps it.
  if (policy != SCHED_OTHER) return "the thread's scheduling policy is not SCHED_OTHER";
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, static_cast<id_t>(thread));  // per thread on Linux
  if (errno != 0) return failed("getpriority");
  SchedAttr attr{};
  attr.size = sizeof attr;
  attr.sched_policy = SCHED_OTHER;
  attr.sched_nice = nice;  // sched_setattr sets the nice value too: keep the thread's own
  attr.sched_runtime = static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(slice).count());
  if (syscall(SYS_sched_setattr, thread, &attr, 0u) != 0) return failed("sched_setattr");
  return std::nullopt;
}

#else

std::optional<std::string> request_thread_slice(std::chrono::microseconds) {
  return "custom time slices need Linux";
}

#endif

}  // namespace geoprox::server
