// The bounded compute pool: a fixed number of threads running queries, never the I/O threads.
// try_submit() refuses work once `max_queue` tasks are waiting (the caller answers Overloaded);
// submit() always queues (admin work, reloads). Tasks must not throw (they are wrapped anyway).
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace geoprox::server {

class Metrics;

/// Names the calling thread as top -H, perf and /proc/PID/task/*/comm show it (gp-io-0,
/// gp-compute-1, ...); Linux keeps the first 15 characters. No effect elsewhere.
void name_this_thread(const std::string& name);

class ComputePool {
 public:
  using Task = std::function<void()>;

  ComputePool(unsigned threads, std::size_t max_queue, Metrics* metrics = nullptr);
  ~ComputePool();
  ComputePool(const ComputePool&) = delete;
  ComputePool& operator=(const ComputePool&) = delete;

  /// Queues `task` unless `max_queue` tasks are already waiting; false: refused.
  bool try_submit(Task task);
  /// Queues `task` whatever the backlog.
  void submit(Task task);

  std::size_t waiting() const;
  unsigned threads() const { return static_cast<unsigned>(threads_.size()); }
  /// A suggested retry delay for a refused task: the expected time to drain the backlog
  /// (moving average of task durations x waiting / threads), clamped to [10, 2000] ms.
  std::int64_t retry_after_ms() const;

  /// Runs what is queued, then joins the threads. Idempotent.
  void stop();

 private:
  void worker(unsigned index);

  std::size_t max_queue_;
  Metrics* metrics_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Task> tasks_;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
  std::atomic<std::uint64_t> mean_task_us_{1000};  // exponential moving average
};

}  // namespace geoprox::server
