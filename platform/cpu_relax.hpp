#pragma once
// The CPU's spin-wait hint, for every spin loop in lockstep: one instruction
// per poll of a loop that waits for another core's store.
//
// The choice per architecture (kSpinHintName says which was compiled):
//  * x86-64: PAUSE. It stops the core from piling up speculative loads of the
//    polled line (so the exit from the loop costs no memory-order machine
//    clear) and lends the pipeline to an SMT sibling. Its cost varies by
//    core: about 10 cycles before Skylake, about 140 from Skylake on (Intel's
//    optimisation manual), 14-19 ns on this project's Intel development VM.
//  * AArch64: ISB, not YIELD, not a bare load loop. YIELD is a hint that
//    cores without SMT (nearly every Arm core) execute as a NOP: 0.4 ns on
//    AWS Graviton2 (Neoverse N1) against 13.2 ns for ISB in the measurement
//    that moved Rust's std::hint::spin_loop from YIELD to ISB
//    (rust-lang/rust pull request 84725, 2021); OpenJDK's SpinPause
//    (JDK-8258604) and folly's asm_volatile_pause (pull request 1904, 2022)
//    moved for the same reason; Go's procyield and Linux's own cpu_relax()
//    (arch/arm64/include/asm/vdso/processor.h) still issue YIELD. A loop of
//    YIELD, like a loop with no hint at all, re-issues the load of the
//    polled line every cycle or two: more load traffic on the very line the
//    producer is about to write, and more power, for no earlier exit. ISB
//    lets the pipeline drain before the next instruction is fetched, so a
//    poll costs a few to tens of nanoseconds, the same order as PAUSE, and
//    the loop issues a load per poll, as it does on x86. A wait ends at most
//    one ISB after the store arrives, as it ends one PAUSE after it on x86.
//    Not measured on arm64 hardware here (this project has none; an emulated
//    CPU's timings mean nothing): every result file records what one poll
//    cost on its machine (spin_poll_ns, platform/wait_calibration.hpp), so a
//    user's arm64 run says it.
//  * elsewhere: a compiler barrier only (the loop still re-reads memory).
// Spin budgets never count hints as if they had a known cost: they are times,
// turned into a number of polls by the start-up calibration
// (platform/wait_calibration.hpp), so a budget lasts the same on a core whose
// hint costs 0.4 ns as on one whose hint costs 40.
#include <string_view>
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace lockstep::platform {

// Tells the core that this is a spin-wait (see the header for the choice).
inline void cpu_relax() noexcept {
#if defined(__x86_64__) || defined(__i386__)
  _mm_pause();
#elif defined(__aarch64__)
  asm volatile("isb" ::: "memory");
#else
  asm volatile("" ::: "memory");
#endif
}

// The instruction cpu_relax() issues, for the result's context.
inline constexpr std::string_view kSpinHintName =
#if defined(__x86_64__) || defined(__i386__)
    "pause";
#elif defined(__aarch64__)
    "isb";
#else
    "none (a compiler barrier)";
#endif

// cpu_relax as a type, the default hint of the spin loops (sync/wait_policy.hpp,
// sync/futex_spin.hpp) and of the calibration: a test passes a fake one.
struct cpu_hint {
  void operator()() const noexcept { cpu_relax(); }
};

}  // namespace lockstep::platform
