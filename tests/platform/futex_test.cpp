// platform/futex.hpp: a futex call that fails for good ends the process with a
// line instead of returning "interrupted" to a wait loop that would spin on
// it for ever.
#include <sys/mman.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>

#include "platform/futex.hpp"

namespace {

using lockstep::platform::futex_result;
using lockstep::platform::futex_wait;
using lockstep::platform::futex_wake;

// A word in a page nobody may read: the kernel's read of it fails (EFAULT)
// on every call. Nothing in this process touches the word itself.
std::atomic<std::uint32_t>& unreadable_word() {
  void* page = ::mmap(nullptr, static_cast<std::size_t>(::sysconf(_SC_PAGESIZE)), PROT_NONE,
                      MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (page == MAP_FAILED) std::abort();
  return *static_cast<std::atomic<std::uint32_t>*>(page);
}

TEST(FutexDeathTest, AWaitOnAnUnreadableWordEndsTheProcess) {
  EXPECT_DEATH(futex_wait(unreadable_word(), 0, std::chrono::milliseconds(10)), "FUTEX_WAIT failed: Bad address");
}

// The outcomes a wait loop handles are still returned.
TEST(Futex, ExpectedOutcomesAreReturned) {
  std::atomic<std::uint32_t> word{1};
  EXPECT_EQ(futex_wait(word, 0), futex_result::value_changed);
  EXPECT_EQ(futex_wait(word, 1, std::chrono::microseconds(100)), futex_result::timed_out);
  EXPECT_EQ(futex_wake(word), 0);
}

}  // namespace
