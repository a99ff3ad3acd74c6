#pragma once
// A zero-initialised array of doubles that starts on a chosen boundary and
// owns whole blocks of that size: the storage under every layout. Allocated
// once, before any participant runs; never resized.
//
// Whatever boundary is asked for, the allocation itself starts and ends on a
// prefetch pair (platform::kPrefetchPair), so no other allocation shares a
// pair of lines with it: the adjacent-line prefetcher pulls both lines of a
// pair, and a buffer whose first or last line shared a pair with whatever the
// heap put beside it was slower or not by where the heap happened to put it,
// which differed from process to process (a layout's own lines still share
// pairs exactly as the layout places them: only its neighbours are kept off).
#include <algorithm>
#include <cstddef>
#include <cstring>
#include <new>
#include <utility>

#include "platform/cache_line.hpp"

namespace lockstep::layouts {

// Bytes rounded up to a whole number of `unit` blocks.
[[nodiscard]] constexpr std::size_t round_up(std::size_t bytes, std::size_t unit) noexcept {
  return (bytes + unit - 1) / unit * unit;
}

class aligned_buffer {
 public:
  aligned_buffer() = default;
  // `count` doubles, starting on an `alignment` boundary; the allocation is
  // rounded up to whole `alignment` blocks so that nothing else the allocator
  // hands out shares the buffer's last block.
  aligned_buffer(std::size_t count, std::size_t alignment)
      : count_(count),
        alignment_(alignment),
        data_(static_cast<double*>(::operator new(bytes(), std::align_val_t{allocation_alignment()}))) {
    std::memset(data_, 0, bytes());
  }
  aligned_buffer(const aligned_buffer&) = delete;  // participants hold pointers into it
  aligned_buffer& operator=(const aligned_buffer&) = delete;
  aligned_buffer(aligned_buffer&& other) noexcept
      : count_(std::exchange(other.count_, 0)),
        alignment_(other.alignment_),
        data_(std::exchange(other.data_, nullptr)) {}
  aligned_buffer& operator=(aligned_buffer&& other) noexcept {
    std::swap(count_, other.count_);
    std::swap(alignment_, other.alignment_);
    std::swap(data_, other.data_);
    return *this;
  }
  ~aligned_buffer() {
    if (data_ != nullptr) ::operator delete(data_, std::align_val_t{allocation_alignment()});
  }

  [[nodiscard]] double* data() noexcept { return data_; }
  [[nodiscard]] const double* data() const noexcept { return data_; }
  [[nodiscard]] std::size_t size() const noexcept { return count_; }
  [[nodiscard]] double& operator[](std::size_t index) noexcept { return data_[index]; }
  [[nodiscard]] const double& operator[](std::size_t index) const noexcept { return data_[index]; }

 private:
  [[nodiscard]] std::size_t allocation_alignment() const noexcept {
    return std::max(alignment_, platform::kPrefetchPair);
  }
  [[nodiscard]] std::size_t bytes() const noexcept {
    return round_up(count_ == 0 ? 1 : count_ * sizeof(double), allocation_alignment());
  }

  std::size_t count_ = 0;
  std::size_t alignment_ = alignof(double);
  double* data_ = nullptr;
};

}  // namespace lockstep::layouts
