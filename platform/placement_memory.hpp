#pragma once
// Where memory lives: the NUMA node of each page of a range, as the kernel
// says now. The companion of placement.hpp's first_touch_scope: the scope
// makes participant 0's CPU touch a step's new pages first, and this reads
// where they (and any page the allocator had touched before) actually are,
// so that a run states the node it observed, never the one it hoped for.
#include <cstddef>
#include <vector>

namespace lockstep::platform {

// The page size the kernel maps ordinary memory with (sysconf).
std::size_t page_bytes() noexcept;

// The NUMA node (the kernel's number) of every page that [address, address +
// bytes) touches, in address order; -1 for a page the process has not
// touched yet (no node until its first touch). Empty when the kernel will not
// say (a kernel without NUMA support, or a seccomp filter that refuses
// move_pages). Reading moves nothing.
std::vector<int> memory_nodes_of(const void* address, std::size_t bytes);

}  // namespace lockstep::platform
