#include "server/compute_pool.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <string>

#if defined(__linux__)
#include <pthread.h>
#endif

#include "server/metrics.h"

namespace geoprox::server {

void name_this_thread(const std::string& name) {
#if defined(__linux__)
  pthread_setname_np(pthread_self(), name.substr(0, 15).c_str());
#else
  (void)name;
#endif
}

ComputePool::ComputePool(unsigned threads, std::size_t max_queue, Metrics* metrics)
    : max_queue_(max_queue), metrics_(metrics) {
  if (threads == 0) threads = 1;
  threads_.reserve(threads);
  for (unsigned i = 0; i < threads; ++i) threads_.emplace_back([this, i] { worker(i); });
}

ComputePool::~ComputePool() { stop(); }

bool ComputePool::try_submit(Task task) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || tasks_.size() >= max_queue_) return false;
    tasks_.push_back(std::move(task));
    if (metrics_) metrics_->queue_depth.store(static_cast<std::int64_t>(tasks_.size()));
  }
  cv_.notify_one();
  return true;
}

void ComputePool::submit(Task task) {
  {
    std::lock_guard lock(mutex_);
    tasks_.push_back(std::move(task));
    if (metrics_) metrics_->queue_depth.store(static_cast<std::int64_t>(tasks_.size()));
  }
  cv_.notify_one();
}

std::size_t ComputePool::waiting() const {
  std::lock_guard lock(mutex_);
  return tasks_.size();
}

std::int64_t ComputePool::retry_after_ms() const {
  const double mean_ms = static_cast<double>(mean_task_us_.load(std::memory_order_relaxed)) / 1e3;
  const double backlog = static_cast<double>(waiting()) + 1;
  const double ms = mean_ms * backlog / static_cast<double>(std::max<std::size_t>(1, threads_.size()));
  return std::clamp<std::int64_t>(static_cast<std::int64_t>(ms + 0.5), 10, 2000);
}

void ComputePool::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && threads_.empty()) return;
    stopping_ = true;
  }
  cv_.notify_all();
  for (auto& t : threads_) {
    if (t.joinable()) t.join();
  }
  threads_.clear();
}

void ComputePool::worker(unsigned index) {
  name_this_thread("gp-compute-" + std::to_string(index));
  for (;;) {
    Task task;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [&] { return stopping_ || !tasks_.empty(); });
      if (tasks_.empty()) return;  // stopping and drained
      task = std::move(tasks_.front());
      tasks_.pop_front();
      if (metrics_) metrics_->queue_depth.store(static_cast<std::int64_t>(tasks_.size()));
    }
    const auto start = std::chrono::steady_clock::now();
    try {
      task();
    } catch (const std::exception& e) {
      spdlog::error("compute task threw (a bug): {}", e.what());
    } catch (...) {
      spdlog::error("compute task threw a non-standard exception (a bug)");
    }
    task = nullptr;  // release captures on this thread
    const auto us = static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() -
                                                              start)
            .count());
    const std::uint64_t old = mean_task_us_.load(std::memory_order_relaxed);
    mean_task_us_.store((old * 7 + us) / 8, std::memory_order_relaxed);
  }
}

}  // namespace geoprox::server
