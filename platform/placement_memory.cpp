// The node of each page of a range (placement_memory.hpp).
#include "platform/placement_memory.hpp"

#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>

namespace lockstep::platform {

std::size_t page_bytes() noexcept {
  const long size = ::sysconf(_SC_PAGESIZE);
  return size > 0 ? static_cast<std::size_t>(size) : 4096U;
}

std::vector<int> memory_nodes_of(const void* address, std::size_t bytes) {
  if (address == nullptr || bytes == 0) return {};
  const std::size_t page = page_bytes();
  const auto first = reinterpret_cast<std::uintptr_t>(address) / page * page;
  const auto last = (reinterpret_cast<std::uintptr_t>(address) + bytes - 1) / page * page;
  std::vector<void*> pages;
  for (std::uintptr_t at = first; at <= last; at += page) pages.push_back(reinterpret_cast<void*>(at));
  std::vector<int> status(pages.size(), -1);
  // move_pages(2) with no target nodes moves nothing and reports each page's
  // node in `status` (a negative errno for a page that has none yet). The
  // system call itself, not libnuma's wrapper: this one query is all lockstep
  // asks of NUMA memory, and hwloc's hwloc_get_area_memlocation would need a
  // live hwloc topology, which platform/topology.hpp releases after loading.
  if (::syscall(SYS_move_pages, 0, static_cast<unsigned long>(pages.size()), pages.data(), nullptr, status.data(),
                0) != 0) {
    return {};
  }
  for (int& node : status)
    if (node < 0) node = -1;
  return status;
}

}  // namespace lockstep::platform
