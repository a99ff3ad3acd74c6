// Open MPI's yield-when-idle flag, through its exported symbols (yield_when_idle.hpp).
#include "distributed/yield_when_idle.hpp"

#include <dlfcn.h>

namespace lockstep::distributed {
namespace {

// libopen-pal's progress flag: `bool opal_progress_yield_when_idle` in every
// Open MPI from 1.x to 5.x.
const bool* progress_flag() noexcept {
  return static_cast<const bool*>(::dlsym(RTLD_DEFAULT, "opal_progress_yield_when_idle"));
}

}  // namespace

std::optional<bool> yields_when_idle() noexcept {
  const bool* flag = progress_flag();
  if (flag == nullptr) return std::nullopt;
  return *flag;
}

bool make_yield_when_idle() noexcept {
  // opal_progress_set_yield_when_idle(bool) returns the previous value in
  // some Open MPI versions and nothing in others; called as returning nothing,
  // which is sound for both (a result is left in a register nobody reads).
  void* symbol = ::dlsym(RTLD_DEFAULT, "opal_progress_set_yield_when_idle");
  if (symbol == nullptr || progress_flag() == nullptr) return false;
  using setter = void (*)(bool);
  reinterpret_cast<setter>(symbol)(true);
  return yields_when_idle().value_or(false);
}

}  // namespace lockstep::distributed
