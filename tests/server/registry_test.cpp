// LoadedMesh's scratch pool: a lease hands a compute thread back the slot it used last (whose
// buffers are still in that core's cache) and otherwise any free slot, creating no more slots
// than leases held at once.
#include "server/registry.h"

#include <gtest/gtest.h>

#include <functional>
#include <future>
#include <memory>
#include <optional>

#include "core/graph/graph_file.h"
#include "core/mesh/mesh_io.h"
#include "server/compute_pool.h"
#include "server_test_support.h"

namespace geoprox::server {
namespace {

using testing::cached_graph;
using testing::small_spot_params;
using testing::spot_obj;

// Runs `f` on the pool's one compute thread and waits for it (a compute thread's identity
// stays the same across its leases, as in the daemon).
void run_on(ComputePool& pool, const std::function<void()>& f) {
  std::promise<void> done;
  pool.submit([&] {
    f();
    done.set_value();
  });
  done.get_future().get();
}

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
  ComputePool other(1, 16);
  std::optional<LoadedMesh::Lease> other_lease;
  const QueryScratch* theirs = nullptr;
  std::optional<LoadedMesh::Lease> my_lease(loaded_->lease());
  const QueryScratch* mine = &my_lease->scratch();
  run_on(other, [&] {
    other_lease.emplace(loaded_->lease());
    theirs = &other_lease->scratch();
  });
  ASSERT_NE(mine, theirs);
  // The other thread's slot goes back first and this thread's last: handing out the slot
  // released last would give the other thread this one's.
  run_on(other, [&] { other_lease.reset(); });
  my_lease.reset();
  run_on(other, [&] {
    other_lease.emplace(loaded_->lease());
    EXPECT_EQ(&other_lease->scratch(), theirs);
  });
  my_lease.emplace(loaded_->lease());
  EXPECT_EQ(&my_lease->scratch(), mine);
  EXPECT_EQ(loaded_->scratch_created(), 2u);
  run_on(other, [&] { other_lease.reset(); });
}

TEST_F(RegistryLeaseTest, AnotherThreadsFreeSlotIsTakenWhenItsOwnIsLeased) {
  ComputePool other(1, 16);
  const QueryScratch* theirs = nullptr;
  LoadedMesh::Lease first = loaded_->lease();
  run_on(other, [&] {
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
