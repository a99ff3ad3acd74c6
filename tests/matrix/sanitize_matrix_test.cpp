// The matrix subset that the tsan and asan-ubsan presets run (label
// `sanitize`): every primitive and every layout at least once, on 2 and 4
// threads (and a chain on 8), few steps. Each primitive runs with one layout, the applicable one
// used least so far (layout_rotation, matrix_cases.hpp), so that the layouts
// rotate through the primitives of this build's subset; a layout that no
// primitive took then runs with the first primitive it applies to. Each
// primitive also runs the s-mass chain with its layout: 3 masses on 4 threads
// (uneven blocks), and the chain the harness integrates on 8 threads
// (kernels::model_for(8): 4 masses, one equation per thread), oversubscribed
// on a 2-CPU machine: a barrier's team of eight, and for the dataflow
// primitives a graph in which each participant waits only for the few whose
// equations it reads, so that participants far apart in the chain drift
// stages apart, held only by the channels' back-pressure.
//
// Under ThreadSanitizer the subset is the primitives a TSan run can check
// (sync::checked_by_tsan, from their traits). Left out today:
//  * kVisibleToTsan false: Concurrency Kit's barriers (ck_*) are C with
//    inline-assembly atomics (ck_pr), and libgomp (omp_barrier) is not built
//    with TSan, so the happens-before of their barriers is invisible to it and
//    every handoff would be reported as a race on the layout's plain doubles:
//    false positives;
//  * kMayLoseWakeups: win_event_faithful (the paper's ThreadWaiter) stops
//    ordering the team after a lost wake-up (win_event_faithful.hpp), so TSan
//    then reports, at random (only in a run that loses a wake-up), the race
//    the paper's design causes. tests/sync/win_event_test.cpp drives that lost
//    wake-up deterministically under TSan instead.
// AddressSanitizer + UBSan run them all. A new primitive joins by its traits.
#include "kernels/model_choice.hpp"
#include "tests/matrix/matrix_cases.hpp"

namespace lockstep::testing::matrix {
namespace {

constexpr std::uint64_t kSanitizeSteps = 120;
// The 8-thread chain: each of its stage syncs is eight threads' worth of
// context switches on two CPUs, under a sanitizer's slowdown; a few steps
// (steps_for takes a third of them in a sanitizer build) suffice for the
// sanitizers to see every handoff.
constexpr unsigned kWideChainThreads = 8;
constexpr std::uint64_t kWideChainSteps = 30;

template <class Sync>
constexpr bool in_this_build() {
#if defined(__SANITIZE_THREAD__)
  return sync::checked_by_tsan(sync::info_of<Sync>());
#else
  return true;
#endif
}

template <class Sync, class Layout>
void register_one(unsigned threads) {
  if constexpr (kernels::applicable<Sync, Layout>().applicable && in_this_build<Sync>()) {
    register_scenario("MatrixSanitize", combination_name<Sync, Layout>(threads, placement::none), [threads] {
      expect_bitwise_serial<Sync, Layout>(kernels::two_mass_model{}, threads, placement::none,
                                          steps_for<Sync>(threads, kSanitizeSteps));
    });
  }
}

template <class Sync, class Layout>
void register_chain(std::size_t masses, unsigned threads, std::uint64_t steps) {
  if constexpr (kernels::applicable<Sync, Layout>().applicable && in_this_build<Sync>()) {
    register_scenario("ChainSanitize", chain_name<Sync, Layout>(masses, threads), [masses, threads, steps] {
      const kernels::chain_model chain(kernels::chain_params::uniform(masses));
      expect_bitwise_serial<Sync, Layout>(chain, threads, placement::none, steps_for<Sync>(threads, steps));
    });
  }
}

template <class Sync, class Layout>
void register_with_chains() {
  register_chain<Sync, Layout>(3, 4, kSanitizeSteps);
  register_chain<Sync, Layout>(kernels::model_for(kWideChainThreads).masses, kWideChainThreads, kWideChainSteps);
}

const bool registered = [] {
  layout_rotation rotation;
  sync::for_each_primitive([&rotation]<class Sync>() {
    if constexpr (in_this_build<Sync>()) {
      with_layout<Sync>(rotation.next<Sync>(), []<class Layout>() {
        register_one<Sync, Layout>(4);
        register_one<Sync, Layout>(2);
        register_with_chains<Sync, Layout>();
      });
    }
  });
  cover_unused_layouts(rotation, []<class Sync>() { return in_this_build<Sync>(); }, []<class Sync, class Layout>() {
    register_one<Sync, Layout>(4);
    register_one<Sync, Layout>(2);
  });
  return true;
}();

}  // namespace
}  // namespace lockstep::testing::matrix
