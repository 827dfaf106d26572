// An append-only array in one memory mapping that grows by remapping (no paper: a vector whose
// growth moves page-table entries instead of elements).
//
// The exact solver indexes its windows several times per window. A full solve on a 100k-face
// mesh stores about 3 million 64-byte windows: growing a std::vector to that size copies every
// window about twice and faults every page in twice. Blocks that never move (this file's
// predecessor, a segmented array) avoid that, but each access then loads the block table and
// splits the index, and local solves are faster on one flat array.
// Here the array is one anonymous mapping; growing it asks the kernel to move the pages
// (mremap), so nothing is copied and no page is faulted in again. Past 2 MiB the mapping is
// offered to the kernel as transparent huge pages (a local solve touches a few pages of its
// first 2 MiB and should not commit a whole huge page per solver). The solver keeps its mapping
// between solves (clear() only forgets the elements), so a reused solver allocates only when a
// solve stores more than any before it.
//
// Growth moves the elements' addresses, as a std::vector's does: hold indices, not references,
// across push_back. Elements must be trivially copyable. Elsewhere than Linux the mapping is a
// malloc'd block grown by realloc. Under ThreadSanitizer, growth maps a new block, copies and
// unmaps the old one: TSan does not intercept mremap, so the moved pages would keep whatever
// access history its shadow held for their new addresses (google/sanitizers#1099), and a
// solver on one thread could be reported as racing with a thread that used those addresses
// before.
#pragma once

#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <new>
#include <type_traits>
#include <utility>

#if defined(__linux__)
#include <sys/mman.h>
#endif

// Set when built with ThreadSanitizer (GCC's and Clang's ways of saying so).
#if defined(__SANITIZE_THREAD__)
#define GEOPROX_MAPPED_ARRAY_UNDER_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define GEOPROX_MAPPED_ARRAY_UNDER_TSAN 1
#endif
#endif

namespace geoprox {

template <class T>
class MappedArray {
  static_assert(std::is_trivially_copyable_v<T>);

 public:
  /// The first mapping; growth doubles the capacity from there.
  static constexpr std::size_t kInitialBytes = std::size_t{2} << 20;
  static_assert(kInitialBytes % sizeof(T) == 0);

  MappedArray() = default;
  MappedArray(const MappedArray&) = delete;
  MappedArray& operator=(const MappedArray&) = delete;
  MappedArray(MappedArray&& other) noexcept
      : data_(std::exchange(other.data_, nullptr)),
        size_(std::exchange(other.size_, 0)),
        capacity_(std::exchange(other.capacity_, 0)) {}
  MappedArray& operator=(MappedArray&& other) noexcept {
    if (this != &other) {
      release();
      data_ = std::exchange(other.data_, nullptr);
      size_ = std::exchange(other.size_, 0);
      capacity_ = std::exchange(other.capacity_, 0);
    }
    return *this;
  }
  ~MappedArray() { release(); }

  std::size_t size() const { return size_; }
  std::size_t capacity() const { return capacity_; }
  bool empty() const { return size_ == 0; }
  void clear() { size_ = 0; }

  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }

  void push_back(const T& value) {
    if (size_ == capacity_) grow();
    data_[size_++] = value;
  }

 private:
  void grow() {
    const std::size_t old_bytes = capacity_ * sizeof(T);
    const std::size_t new_bytes = old_bytes == 0 ? kInitialBytes : 2 * old_bytes;
    if (new_bytes / 2 < old_bytes) throw std::bad_alloc();  // overflow
#if defined(__linux__)
    void* grown;
    if (data_ == nullptr || kCopyOnGrowth) {
      grown = mmap(nullptr, new_bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (grown != MAP_FAILED && data_ != nullptr) {
        std::memcpy(grown, data_, old_bytes);
        munmap(data_, old_bytes);
      }
    } else {
      grown = mremap(data_, old_bytes, new_bytes, MREMAP_MAYMOVE);
    }
    if (grown == MAP_FAILED) throw std::bad_alloc();  // the old mapping is left as it was
#if defined(MADV_HUGEPAGE)
    if (new_bytes > kInitialBytes) madvise(grown, new_bytes, MADV_HUGEPAGE);  // a hint only
#endif
#else
    void* grown = std::realloc(data_, new_bytes);
    if (grown == nullptr) throw std::bad_alloc();
#endif
    data_ = static_cast<T*>(grown);
    capacity_ = new_bytes / sizeof(T);
  }
  void release() {
    if (data_ != nullptr) {
#if defined(__linux__)
      munmap(data_, capacity_ * sizeof(T));
#else
      std::free(data_);
#endif
    }
    data_ = nullptr;
    size_ = capacity_ = 0;
  }

#if defined(GEOPROX_MAPPED_ARRAY_UNDER_TSAN)
  static constexpr bool kCopyOnGrowth = true;  // see the header comment
#else
  static constexpr bool kCopyOnGrowth = false;
#endif

  T* data_ = nullptr;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;
};

}  // namespace geoprox
