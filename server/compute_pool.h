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
#include <utility>
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
  /// A request's task: admin work (`admin`) is queued whatever the backlog (submit), a query
  /// only while the queue has room (try_submit). False: refused.
  bool submit_request(Task task, bool admin) {
    if (!admin) return try_submit(std::move(task));
    submit(std::move(task));
    return true;
  }

  /// Runs `first` on the calling thread and `second` on an idle worker if one is waiting for
  /// work (else on the calling thread after `first`); returns once both are done and rethrows
  /// the exception of `first`, else of `second`. For the two halves of one query: at low load
  /// a near pair's two exact solves then run at once; under load nothing is lent (no worker is
  /// idle) and nothing changes. A lent half that no worker has started yet when `first` ends is
  /// taken back, so the caller never waits on the queue (a worker may call this too).
  void run_both(const std::function<void()>& first, const std::function<void()>& second);

  std::size_t waiting() const;
  /// Workers waiting for a task.
  unsigned idle_threads() const;
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
  unsigned idle_ = 0;  // workers waiting for a task
  std::vector<std::thread> threads_;
  std::atomic<std::uint64_t> mean_task_us_{1000};  // exponential moving average
};

}  // namespace geoprox::server
