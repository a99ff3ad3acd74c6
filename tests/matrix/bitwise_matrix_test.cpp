// The correctness oracle of the benchmark matrix (issue 4): every applicable
// sync x layout, on 1, 2 and 4 threads, unpinned and compact, reproduces the
// serial staged RK4 trajectory bit for bit; and the s-mass chain (uneven
// blocks, three-way dependencies) on several thread counts. A combination
// that is not applicable is a test too: it must say why.
#include "tests/matrix/matrix_cases.hpp"

namespace lockstep::testing::matrix {
namespace {

// Paper's case: 300 steps (0.3 s, about one period of the slow mode).
constexpr std::uint64_t kPaperSteps = 300;
// Chains: fewer steps, more equations.
constexpr std::uint64_t kChainSteps = 120;

template <class Sync, class Layout>
void register_two_mass() {
  if constexpr (kernels::applicable<Sync, Layout>().applicable) {
    for (unsigned threads : {1U, 2U, 4U})
      for (placement pin : {placement::none, placement::compact})
        register_scenario("Matrix", combination_name<Sync, Layout>(threads, pin), [threads, pin] {
          expect_bitwise_serial<Sync, Layout>(kernels::two_mass_model{}, threads, pin,
                                              steps_for<Sync>(threads, kPaperSteps));
        });
  } else {
    register_scenario("NotApplicable", std::string(Sync::kName) + "/" + std::string(Layout::kName), [] {
      constexpr kernels::applicability verdict = kernels::applicable<Sync, Layout>();
      EXPECT_FALSE(verdict.reason.empty()) << "a combination that is not applicable must say why";
      EXPECT_EQ((kernels::not_applicable_reason<Sync, Layout>(4, 4)), std::string(verdict.reason));
    });
  }
}

// Chains: 3 masses (6 equations) on 4 threads gives blocks of 2, 2, 1, 1;
// 5 masses (10 equations) on 3 threads gives 4, 3, 3. Two layouts per
// primitive keep the count down: padded64 (shared, in place) and per_thread
// (private copy; the only one for channels).
template <class Sync, class Layout>
void register_chain() {
  if constexpr (kernels::applicable<Sync, Layout>().applicable) {
    for (std::size_t masses : {3U, 5U})
      for (unsigned threads : {2U, 3U, 4U})
        register_scenario("Chain",
                          std::string(Sync::kName) + "/" + std::string(Layout::kName) + "/masses" +
                              std::to_string(masses) + "/threads" + std::to_string(threads),
                          [masses, threads] {
                            const kernels::chain_model chain(kernels::chain_params::uniform(masses));
                            expect_bitwise_serial<Sync, Layout>(chain, threads, placement::none,
                                                                steps_for<Sync>(threads, kChainSteps));
                          });
  }
}

const bool registered = [] {
  sync::for_each_primitive([]<class Sync>() {
    for_each_layout([]<class Layout>() { register_two_mass<Sync, Layout>(); });
    register_chain<Sync, layouts::padded64>();
    register_chain<Sync, layouts::per_thread>();
  });
  return true;
}();

}  // namespace
}  // namespace lockstep::testing::matrix
