#pragma once
// Where a primitive keeps the words its participants share: the storage
// policy of the primitives that can also synchronise processes (mailbox).
//
//   heap_storage            the default: the primitive's own heap arrays,
//                           process-private futexes. Owns what it hands out.
//   process_shared_storage  a block of memory that several processes map (an
//                           MPI-3 shared window, distributed/shm_window.hpp),
//                           shared futexes. Owns nothing.
//
// Contract (both): make_array<T>(n) returns n value-initialised T, aligned
// for T; bytes() is what the calls so far took, alignment included (so a
// primitive built once on heap_storage says how large a shared block the same
// arguments need). For process_shared_storage every process constructs the
// primitive over the same block with the same arguments: the same sequence
// of calls hands out the same offsets everywhere. Only the initialiser
// constructs the arrays and writes first values (initialises() is true there
// alone); the others take the addresses. Nobody may use the primitive before
// every process has constructed it (the caller's barrier: in
// distributed/shm_window.cpp MPI_Win_sync, MPI_Barrier, MPI_Win_sync), which
// also publishes the initialiser's writes.
// Objects placed in shared storage must own nothing (no heap pointer another
// process could not follow): arrays of atomics and plain values.
#include <cstddef>
#include <memory>
#include <new>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "platform/futex.hpp"

namespace lockstep::sync {

class heap_storage {
 public:
  static constexpr platform::futex_scope kScope = platform::futex_scope::process_private;

  template <class T>
  T* make_array(std::size_t count) {
    std::shared_ptr<T[]> owned(new T[count]());  // aligned new for over-aligned T
    T* const first = owned.get();
    owned_.push_back(std::move(owned));
    bytes_ += (bytes_ + alignof(T) - 1) / alignof(T) * alignof(T) - bytes_ + count * sizeof(T);
    return first;
  }
  template <class T, class... Args>
  T* make(Args&&... args) {
    std::shared_ptr<T> owned = std::make_shared<T>(std::forward<Args>(args)...);
    T* const object = owned.get();
    owned_.push_back(std::move(owned));
    bytes_ += (bytes_ + alignof(T) - 1) / alignof(T) * alignof(T) - bytes_ + sizeof(T);
    return object;
  }
  [[nodiscard]] bool initialises() const noexcept { return true; }
  [[nodiscard]] std::size_t bytes() const noexcept { return bytes_; }

 private:
  std::vector<std::shared_ptr<void>> owned_;
  std::size_t bytes_ = 0;
};

class process_shared_storage {
 public:
  static constexpr platform::futex_scope kScope = platform::futex_scope::process_shared;

  // `block` must be aligned to at least the largest alignment handed out (a
  // prefetch pair, 128 bytes). An MPI shared window's base is not: Open MPI
  // 4.1's osc/sm hands out bases 8 bytes past a page boundary, so the caller
  // rounds the block's start up from the base and allocates the slack that
  // takes (distributed/shm_window.cpp, distributed/shared_window_layout.hpp).
  process_shared_storage(std::byte* block, std::size_t capacity, bool initialiser) noexcept
      : block_(block), capacity_(capacity), initialiser_(initialiser) {}

  template <class T>
  T* make_array(std::size_t count) {
    static_assert(std::is_trivially_destructible_v<T>, "shared storage is never destroyed element by element");
    T* const first = reserve<T>(count);
    if (!initialiser_) return std::launder(first);
    for (std::size_t index = 0; index < count; ++index) new (first + index) T();
    return first;
  }
  template <class T, class... Args>
  T* make(Args&&... args) {
    static_assert(std::is_trivially_destructible_v<T>, "shared storage is never destroyed object by object");
    T* const place = reserve<T>(1);
    if (!initialiser_) return std::launder(place);
    return new (place) T(std::forward<Args>(args)...);
  }
  [[nodiscard]] bool initialises() const noexcept { return initialiser_; }
  [[nodiscard]] std::size_t bytes() const noexcept { return used_; }

 private:
  template <class T>
  T* reserve(std::size_t count) {
    const std::size_t offset = (used_ + alignof(T) - 1) / alignof(T) * alignof(T);
    if (offset + count * sizeof(T) > capacity_)
      throw std::length_error("process_shared_storage: the shared block is too small for the primitive");
    used_ = offset + count * sizeof(T);
    return reinterpret_cast<T*>(block_ + offset);
  }

  std::byte* block_;
  std::size_t capacity_;
  bool initialiser_;
  std::size_t used_ = 0;
};

}  // namespace lockstep::sync
