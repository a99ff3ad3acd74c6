#pragma once
// Where lockstep's own objects go in an MPI-3 shared window
// (distributed/shm_window.hpp). A window's base is not aligned for them:
// Open MPI 4.1's osc/sm hands out rank 0's memory 8 bytes past the start of
// its shared-memory segment (the segment's header comes first), so the base
// is 8 mod 64 (264 mod 4096 with Debian's Open MPI 4.1.4), while
// sync::process_shared_futex_spin needs a prefetch pair (128 bytes) and the
// mailbox's storage (sync/storage.hpp) as much. So every object's place is
// rounded up from the base, and the window is allocated with the slack that
// takes.
//
// Every rank computes the place from the base its own MPI_Win_shared_query
// returns. The ranks map the segment at addresses of their own, but each
// mapping starts on a page, so a base's offset within a page, and with it the
// rounding below (to at most a page), is the same in every rank;
// shm_window.cpp checks that the ranks agree before anyone uses the window.
// No MPI here: tests/sync/process_shared_test.cpp places the same objects in
// a mapping of its own whose base is 8 mod 64, as Open MPI's is.
#include <cstddef>
#include <cstdint>
#include <new>

#include "platform/cache_line.hpp"
#include "sync/futex_spin.hpp"

namespace lockstep::distributed {

// The page size the rounding stays within (the smallest Linux maps).
inline constexpr std::size_t kSmallestPage = 4096;

// Bytes from `base` to the first address at or after it that is a multiple of
// `alignment` (a power of two, at most kSmallestPage).
[[nodiscard]] inline std::size_t alignment_gap(const std::byte* base, std::size_t alignment) noexcept {
  const auto address = reinterpret_cast<std::uintptr_t>(base);
  return static_cast<std::size_t>((alignment - address % alignment) % alignment);
}

// shm_window's window (futex_spin): up to kAlignment - 1 bytes of slack, the
// barrier on its alignment, then, from the next cache line after the barrier,
// the stage values. Nothing else shares a line with the barrier: its start is
// aligned, and its size is rounded up to whole lines before the values.
class barrier_window_layout {
 public:
  using barrier_type = sync::process_shared_futex_spin;
  static constexpr std::size_t kAlignment = alignof(barrier_type);
  static constexpr std::size_t kValuesOffset =
      (sizeof(barrier_type) + platform::kCacheLine - 1) / platform::kCacheLine * platform::kCacheLine;
  static_assert(kAlignment <= kSmallestPage, "the rounding must stay within a page to be the same in every rank");
  static_assert(kAlignment % platform::kCacheLine == 0, "the values after the barrier start on a line");

  // The bytes a window needs for `value_bytes` of values after the barrier,
  // whatever its base's alignment.
  [[nodiscard]] static constexpr std::size_t window_bytes(std::size_t value_bytes) noexcept {
    return kAlignment - 1 + kValuesOffset + value_bytes;
  }

  // `base`: the window's base as this process sees it.
  explicit barrier_window_layout(std::byte* base) noexcept : offset_(alignment_gap(base, kAlignment)), base_(base) {}

  // The barrier's offset from the base (what the ranks compare).
  [[nodiscard]] std::size_t barrier_offset() const noexcept { return offset_; }
  [[nodiscard]] std::byte* barrier_place() const noexcept { return base_ + offset_; }
  [[nodiscard]] std::byte* values_place() const noexcept { return base_ + offset_ + kValuesOffset; }

  // The initialiser constructs the barrier for `participants`; the others
  // take its address (the caller's barrier orders the two, as in
  // sync/storage.hpp).
  [[nodiscard]] barrier_type* place_barrier(bool initialiser, unsigned participants) const {
    if (initialiser) return new (barrier_place()) barrier_type(participants);
    return std::launder(reinterpret_cast<barrier_type*>(barrier_place()));
  }

 private:
  std::size_t offset_;
  std::byte* base_;
};

}  // namespace lockstep::distributed
