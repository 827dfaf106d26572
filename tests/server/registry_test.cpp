// LoadedMesh's scratch pool: a lease hands a compute thread back the slot it used last (whose
// buffers are still in that core's cache) and otherwise any free slot, creating no more slots
// than leases held at once.
#include "server/registry.h"

#include <gtest/gtest.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "core/graph_file.h"
#include "core/mesh_io.h"
#include "server_test_support.h"

namespace geoprox::server {
namespace {

using testing::cached_graph;
using testing::small_spot_params;
using testing::spot_obj;

// One long-lived thread that runs what it is given, one call at a time (a compute thread's
// identity must stay the same across its leases).
class OneThread {
 public:
  OneThread() : thread_([this] { run(); }) {}
  ~OneThread() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  /// Runs `f` on the thread and waits for it.
  void call(std::function<void()> f) {
    std::packaged_task<void()> task(std::move(f));
    std::future<void> done = task.get_future();
    {
      std::lock_guard lock(mutex_);
      tasks_.push_back(std::move(task));
    }
    cv_.notify_all();
    done.get();
  }

 private:
  void run() {
    std::unique_lock lock(mutex_);
    for (;;) {
      cv_.wait(lock, [&] { return stop_ || !tasks_.empty(); });
      if (tasks_.empty()) return;
      std::packaged_task<void()> task = std::move(tasks_.front());
      tasks_.pop_front();
      lock.unlock();
      task();
      lock.lock();
    }
  }
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<std::packaged_task<void()>> tasks_;
  bool stop_ = false;
  std::thread thread_;
};

class RegistryLeaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    data_ = std::make_shared<const MeshData>(load_mesh(spot_obj().string()));
    loaded_ = std::make_unique<LoadedMesh>(
        data_, MappedGraphFile::open(cached_graph(spot_obj(), small_spot_params()).string()), 2);
  }
  std::shared_ptr<const MeshData> data_;
  std::unique_ptr<LoadedMesh> loaded_;
};

TEST_F(RegistryLeaseTest, AThreadGetsBackTheSlotItUsedLast) {
  OneThread other;
  std::optional<LoadedMesh::Lease> other_lease;
  const QueryScratch* theirs = nullptr;
  std::optional<LoadedMesh::Lease> my_lease(loaded_->lease());
  const QueryScratch* mine = &my_lease->scratch();
  other.call([&] {
    other_lease.emplace(loaded_->lease());
    theirs = &other_lease->scratch();
  });
  ASSERT_NE(mine, theirs);
  // The other thread's slot goes back first and this thread's last: handing out the slot
  // released last would give the other thread this one's.
  other.call([&] { other_lease.reset(); });
  my_lease.reset();
  other.call([&] {
    other_lease.emplace(loaded_->lease());
    EXPECT_EQ(&other_lease->scratch(), theirs);
  });
  my_lease.emplace(loaded_->lease());
  EXPECT_EQ(&my_lease->scratch(), mine);
  EXPECT_EQ(loaded_->scratch_created(), 2u);
  other.call([&] { other_lease.reset(); });
}

TEST_F(RegistryLeaseTest, AnotherThreadsFreeSlotIsTakenWhenItsOwnIsLeased) {
  OneThread other;
  const QueryScratch* theirs = nullptr;
  LoadedMesh::Lease first = loaded_->lease();
  other.call([&] {
    LoadedMesh::Lease lease = loaded_->lease();
    theirs = &lease.scratch();
  });
  ASSERT_NE(&first.scratch(), theirs);
  // This thread still holds its own slot: a second lease takes the free one, creating none.
  LoadedMesh::Lease second = loaded_->lease();
  EXPECT_EQ(&second.scratch(), theirs);
  EXPECT_EQ(loaded_->scratch_created(), 2u);
}

}  // namespace
}  // namespace geoprox::server
