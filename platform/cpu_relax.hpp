#pragma once
// The CPU's spin-wait hint, for every spin loop in lockstep.
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace lockstep::platform {

// Tells the core that this is a spin-wait: on x86 PAUSE stops speculative loads
// from piling up (and yields the pipeline to an SMT sibling); on AArch64 YIELD.
inline void cpu_relax() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#elif defined(__aarch64__)
  asm volatile("yield" ::: "memory");
#else
  asm volatile("" ::: "memory");
#endif
}

}  // namespace lockstep::platform
