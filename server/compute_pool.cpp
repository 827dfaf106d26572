#include "server/compute_pool.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <exception>
#include <memory>
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

namespace {

// The half of a run_both() call lent to the pool: whoever claims it first (a worker, or the
// caller taking it back) runs it.
struct LentHalf {
  enum class State { Waiting, Running, Done, TakenBack };
  std::mutex mutex;
  std::condition_variable done;
  State state = State::Waiting;
  std::exception_ptr error;
  const std::function<void()>* work = nullptr;  // the caller's, alive until Done or TakenBack
};

}  // namespace

void ComputePool::run_both(const std::function<void()>& first,
                           const std::function<void()>& second) {
  std::shared_ptr<LentHalf> lent;
  {
    std::lock_guard lock(mutex_);
    if (!stopping_ && idle_ > tasks_.size()) {  // a worker would start it at once
      lent = std::make_shared<LentHalf>();
      lent->work = &second;
      tasks_.push_front([lent, metrics = metrics_] {
        {
          std::lock_guard claim(lent->mutex);
          if (lent->state != LentHalf::State::Waiting) return;  // taken back
          lent->state = LentHalf::State::Running;
        }
        if (metrics) metrics->split_halves.fetch_add(1, std::memory_order_relaxed);
        std::exception_ptr error;
        try {
          (*lent->work)();
        } catch (...) {
          error = std::current_exception();
        }
        {
          std::lock_guard finish(lent->mutex);
          lent->error = error;
          lent->state = LentHalf::State::Done;
        }
        lent->done.notify_one();
      });
      if (metrics_) metrics_->queue_depth.store(static_cast<std::int64_t>(tasks_.size()));
    }
  }
  if (!lent) {
    first();
    second();
    return;
  }
  cv_.notify_one();
  std::exception_ptr first_error;
  try {
    first();
  } catch (...) {
    first_error = std::current_exception();
  }
  std::unique_lock lock(lent->mutex);
  if (lent->state == LentHalf::State::Waiting) {
    lent->state = LentHalf::State::TakenBack;
    lock.unlock();
    if (first_error) std::rethrow_exception(first_error);
    second();
    return;
  }
  // A worker runs it, on the caller's objects: wait whatever `first` did.
  lent->done.wait(lock, [&] { return lent->state == LentHalf::State::Done; });
  if (first_error) std::rethrow_exception(first_error);
  if (lent->error) std::rethrow_exception(lent->error);
}

std::size_t ComputePool::waiting() const {
  std::lock_guard lock(mutex_);
  return tasks_.size();
}

unsigned ComputePool::idle_threads() const {
  std::lock_guard lock(mutex_);
  return idle_;
}

std::int64_t ComputePool::retry_after_ms() const {
  const double mean_ms = static_cast<double>(mean_task_us_.load(std::memory_order_relaxed)) / 1e3;
  const double backlog = static_cast<double>(waiting()) + 1;
  const double threads = static_cast<double>(std::max<std::size_t>(1, threads_.size()));
  const double ms = mean_ms * backlog / threads;
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
      ++idle_;
      cv_.wait(lock, [&] { return stopping_ || !tasks_.empty(); });
      --idle_;
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
