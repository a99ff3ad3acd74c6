// The matrix subset that the tsan and asan-ubsan presets run (label
// `sanitize`): every primitive and every layout at least once, on 2 and 4
// threads, few steps. Each primitive runs with one layout, rotating through
// the layouts so that all four appear; channels run with per_thread, their
// only applicable layout; std_barrier runs with every layout.
//
// Under ThreadSanitizer only, two families are left out:
//  * ck_*: Concurrency Kit's barriers are C with inline-assembly atomics
//    (ck_pr), which TSan does not see, so every handoff through them would be
//    reported as a race on the layout's plain doubles: false positives.
//  * omp_barrier: libgomp is not built with TSan, so the happens-before of
//    `#pragma omp barrier` is invisible to it: the same false positives.
// and one primitive whose race is real and intended:
//  * win_event_faithful (the paper's ThreadWaiter) stops ordering the team
//    after a lost wake-up (win_event_faithful.hpp), so TSan then reports, at
//    random (only in a run that loses a wake-up), the race the paper's design
//    causes. tests/sync/win_event_test.cpp drives that lost wake-up
//    deterministically under TSan instead.
// AddressSanitizer + UBSan run them all.
#include "tests/matrix/matrix_cases.hpp"

namespace lockstep::testing::matrix {
namespace {

constexpr std::uint64_t kSanitizeSteps = 120;

template <class Sync>
constexpr bool excluded_under_tsan() {
#if defined(__SANITIZE_THREAD__)
  constexpr std::string_view name = Sync::kName;
  return name.starts_with("ck_") || name == "omp_barrier" || sync::info_of<Sync>().may_lose_wakeups;
#else
  return false;
#endif
}

template <class Sync, class Layout>
void register_one(unsigned threads) {
  if constexpr (kernels::applicable<Sync, Layout>().applicable && !excluded_under_tsan<Sync>()) {
    register_scenario("MatrixSanitize", combination_name<Sync, Layout>(threads, placement::none), [threads] {
      expect_bitwise_serial<Sync, Layout>(kernels::two_mass_model{}, threads, placement::none,
                                          steps_for<Sync>(threads, kSanitizeSteps));
    });
  }
}

template <class Sync, class Layout>
void register_with_chain() {
  if constexpr (kernels::applicable<Sync, Layout>().applicable && !excluded_under_tsan<Sync>()) {
    register_scenario("ChainSanitize", std::string(Sync::kName) + "/" + std::string(Layout::kName) + "/masses3/threads4",
                      [] {
                        const kernels::chain_model chain(kernels::chain_params::uniform(3));
                        expect_bitwise_serial<Sync, Layout>(chain, 4, placement::none,
                                                            steps_for<Sync>(4, kSanitizeSteps));
                      });
  }
}

const bool registered = [] {
  unsigned rotation = 0;
  sync::for_each_primitive([&rotation]<class Sync>() {
    unsigned layout_index = 0;
    const unsigned chosen = rotation++ % 4;
    for_each_layout([&]<class Layout>() {
      const bool everything = Sync::kName == std::string_view("std_barrier");
      const bool channel = !kernels::applicable<Sync, layouts::packed>().applicable;
      if (everything || channel || layout_index == chosen) {
        register_one<Sync, Layout>(4);
        register_one<Sync, Layout>(2);
      }
      ++layout_index;
    });
    register_with_chain<Sync, layouts::per_thread>();
  });
  return true;
}();

}  // namespace
}  // namespace lockstep::testing::matrix
