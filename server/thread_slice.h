// The scheduler time slice a thread asks for. Under Linux's EEVDF scheduler (6.12 and later) a
// thread that wakes with a shorter slice than the running thread's may preempt it at once,
// instead of waiting until that thread's slice ends. geoproxd's I/O threads ask for a short
// slice: they wake often to do a little work (a reply to write, a request to read) while the
// compute threads hold the cores for milliseconds at a time (docs/daemon.md, "Threads").
//
// Threads: affects the calling thread only; safe to call from any thread.
#pragma once

#include <chrono>
#include <optional>
#include <string>

namespace geoprox::server {

/// Asks the kernel for a time slice of `slice` for the calling thread (sched_setattr with
/// sched_runtime under SCHED_OTHER, the thread's nice value kept). The kernel clamps it to
/// [100 us, 100 ms]; kernels before 6.12 accept and ignore it. nullopt: asked; else why not
/// (another system, a thread under another scheduling policy, or the kernel's refusal).
std::optional<std::string> request_thread_slice(std::chrono::microseconds slice);

}  // namespace geoprox::server
