// An append-only array in fixed 2 MiB blocks (no paper: a segmented vector).
//
// A full exact solve on a 100k-face mesh stores about 3 million 64-byte windows. Growing one
// std::vector to that size copies every window about twice and faults every page in twice; in
// blocks that never move, nothing is copied, and on Linux each block after the first is offered
// to the kernel as a transparent huge page, which turns ~50,000 page faults into ~100. The
// solver keeps its blocks between solves (clear() only forgets the elements), so a reused solver
// allocates only when a solve stores more than any before it. Elements must be trivially
// copyable; indexing costs one extra load (the block table is small and stays in cache).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace geoprox {

template <class T>
class SegmentedArray {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  static constexpr std::size_t kBlockBytes = std::size_t{2} << 20;
  static constexpr std::size_t kPerBlock = kBlockBytes / sizeof(T);
  static_assert(kPerBlock > 0 && (kPerBlock & (kPerBlock - 1)) == 0,
                "sizeof(T) must divide the block into a power of two");

  SegmentedArray() = default;
  SegmentedArray(const SegmentedArray&) = delete;
  SegmentedArray& operator=(const SegmentedArray&) = delete;
  SegmentedArray(SegmentedArray&& other) noexcept
      : blocks_(std::move(other.blocks_)), size_(std::exchange(other.size_, 0)) {}
  SegmentedArray& operator=(SegmentedArray&& other) noexcept {
    if (this != &other) {
      release();
      blocks_ = std::move(other.blocks_);
      size_ = std::exchange(other.size_, 0);
    }
    return *this;
  }
  ~SegmentedArray() { release(); }

  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  void clear() { size_ = 0; }

  T& operator[](std::size_t i) { return blocks_[i / kPerBlock][i % kPerBlock]; }
  const T& operator[](std::size_t i) const { return blocks_[i / kPerBlock][i % kPerBlock]; }

  void push_back(const T& value) {
    if (size_ == blocks_.size() * kPerBlock) add_block();
    (*this)[size_++] = value;
  }

 private:
  // Blocks are mapped straight from the kernel: from malloc, 2 MiB-aligned 2 MiB blocks come
  // from the heap once glibc's mmap threshold has risen, and alignment padding doubles them.
  void add_block() {
    blocks_.push_back(nullptr);  // grow the table first: a throw then leaks no block
#if defined(__linux__)
    // Map twice the size and keep the aligned middle (huge pages need 2 MiB alignment).
    void* mapped = mmap(nullptr, 2 * kBlockBytes, PROT_READ | PROT_WRITE,
                        MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (mapped == MAP_FAILED) {
      blocks_.pop_back();
      throw std::bad_alloc();
    }
    auto* base = static_cast<char*>(mapped);
    const std::size_t head = (kBlockBytes - reinterpret_cast<std::uintptr_t>(base) % kBlockBytes) %
                             kBlockBytes;
    if (head > 0) munmap(base, head);
    munmap(base + head + kBlockBytes, kBlockBytes - head);
    void* block = base + head;
#if defined(MADV_HUGEPAGE)
    // From the second block on: a small solve (a query's local disk) touches a few pages of the
    // first block and should not commit a whole 2 MiB page per solver. A hint only.
    if (blocks_.size() > 1) madvise(block, kBlockBytes, MADV_HUGEPAGE);
#endif
#else
    void* block = std::aligned_alloc(kBlockBytes, kBlockBytes);
    if (block == nullptr) {
      blocks_.pop_back();
      throw std::bad_alloc();
    }
#endif
    blocks_.back() = static_cast<T*>(block);
  }
  void release() {
    for (T* block : blocks_) {
#if defined(__linux__)
      munmap(block, kBlockBytes);
#else
      std::free(block);
#endif
    }
    blocks_.clear();
    size_ = 0;
  }

  std::vector<T*> blocks_;
  std::size_t size_ = 0;
};

}  // namespace geoprox
