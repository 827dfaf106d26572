// ComputePool::run_both: both halves run exactly once, on two threads when a worker is idle,
// on the caller alone when none is, and their exceptions reach the caller.
#include "server/compute_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <future>
#include <stdexcept>
#include <thread>
#include <vector>

namespace geoprox::server {
namespace {

using namespace std::chrono_literals;

void wait_until_idle(const ComputePool& pool, unsigned threads) {
  const auto until = std::chrono::steady_clock::now() + 10s;
  while (pool.idle_threads() < threads && std::chrono::steady_clock::now() < until) {
    std::this_thread::sleep_for(1ms);
  }
  ASSERT_EQ(pool.idle_threads(), threads);
}

TEST(ComputePool, RunBothLendsTheSecondHalfToAnIdleWorker) {
  ComputePool pool(2, 16);
  wait_until_idle(pool, 2);
  std::promise<std::thread::id> first_thread, second_thread;
  std::atomic<bool> second_started{false};
  bool overlapped = false;
  pool.submit([&] {
    pool.run_both(
        [&] {
          first_thread.set_value(std::this_thread::get_id());
          // The second half runs meanwhile on the other worker: it starts while this one waits.
          const auto until = std::chrono::steady_clock::now() + 10s;
          while (!second_started.load() && std::chrono::steady_clock::now() < until) {
            std::this_thread::sleep_for(100us);
          }
          overlapped = second_started.load();
        },
        [&] {
          second_started.store(true);
          second_thread.set_value(std::this_thread::get_id());
        });
  });
  const auto a = first_thread.get_future().get();
  const auto b = second_thread.get_future().get();
  pool.stop();
  EXPECT_TRUE(overlapped);
  EXPECT_NE(a, b);
}

TEST(ComputePool, RunBothWithNoIdleWorkerRunsBothHalvesInOrderOnTheCaller) {
  ComputePool pool(1, 16);
  std::promise<void> done;
  std::vector<int> order;
  std::thread::id caller, first_on, second_on;
  pool.submit([&] {
    caller = std::this_thread::get_id();
    pool.run_both(
        [&] {
          order.push_back(1);
          first_on = std::this_thread::get_id();
        },
        [&] {
          order.push_back(2);
          second_on = std::this_thread::get_id();
        });
    done.set_value();
  });
  ASSERT_EQ(done.get_future().wait_for(10s), std::future_status::ready);
  pool.stop();
  EXPECT_EQ(order, (std::vector<int>{1, 2}));
  EXPECT_EQ(first_on, caller);
  EXPECT_EQ(second_on, caller);
}

TEST(ComputePool, RunBothRunsEachHalfExactlyOnceWhateverWinsTheRace) {
  // The caller here is not a worker, so both workers are idle and the second half is lent
  // every time; whether a worker or the caller (taking it back) runs it is a race.
  ComputePool pool(2, 16);
  wait_until_idle(pool, 2);
  int lent = 0;
  for (int round = 0; round < 2000; ++round) {
    int first = 0, second = 0;
    std::thread::id second_on;
    // A first half of 0, 20 or 40 us: the worker sometimes starts the second half first.
    const auto spin = std::chrono::microseconds(20 * (round % 3));
    pool.run_both(
        [&] {
          ++first;
          const auto until = std::chrono::steady_clock::now() + spin;
          while (std::chrono::steady_clock::now() < until) {
          }
        },
                  [&] {
                    ++second;
                    second_on = std::this_thread::get_id();
                  });
    ASSERT_EQ(first, 1) << "round " << round;
    ASSERT_EQ(second, 1) << "round " << round;
    lent += second_on != std::this_thread::get_id();
  }
  std::printf("second half run by a worker in %d of 2000 rounds\n", lent);
}

TEST(ComputePool, RunBothRethrowsTheFirstHalfsExceptionThenTheSeconds) {
  ComputePool pool(2, 16);
  for (int round = 0; round < 200; ++round) {
    std::atomic<int> ran{0};
    EXPECT_THROW(pool.run_both([&] { ++ran; throw std::runtime_error("first"); },
                               [&] { ++ran; }),
                 std::runtime_error);
    EXPECT_LE(ran.load(), 2);
    try {
      pool.run_both([] {}, [] { throw std::invalid_argument("second"); });
      ADD_FAILURE() << "the second half's exception was lost";
    } catch (const std::invalid_argument& e) {
      EXPECT_STREQ(e.what(), "second");
    }
    try {
      pool.run_both([] { throw std::runtime_error("first"); },
                    [] { throw std::invalid_argument("second"); });
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "first");
    }
  }
}

TEST(ComputePool, RunBothAfterStopRunsOnTheCaller) {
  ComputePool pool(2, 16);
  pool.stop();
  int first = 0, second = 0;
  pool.run_both([&] { ++first; }, [&] { ++second; });
  EXPECT_EQ(first, 1);
  EXPECT_EQ(second, 1);
}

}  // namespace
}  // namespace geoprox::server
