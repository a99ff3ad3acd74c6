// The correctness oracle of the benchmark matrix (issue 4): every applicable
// sync x layout, on 1, 2 and 4 threads, unpinned and compact, reproduces the
// serial staged RK4 trajectory bit for bit; and the s-mass chain (uneven
// blocks, three-way dependencies) on several thread counts, with every
// applicable layout. A combination that is not applicable is a test too: it
// must say why.
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

// Chains, with every applicable layout (the paper's four equations split
// evenly on 1, 2 and 4 threads; a layout's offsets for uneven blocks are
// checked here): 3 masses (6 equations) on 4 threads gives blocks of 2, 2, 1,
// 1; 5 masses (10 equations) on 3 threads gives 4, 3, 3, and on 2 threads
// two blocks of 5 with dependencies inside each.
template <class Sync, class Layout>
void register_chain() {
  if constexpr (kernels::applicable<Sync, Layout>().applicable) {
    struct shape {
      std::size_t masses;
      unsigned threads;
    };
    for (const shape chain_shape : {shape{3, 4}, shape{5, 3}, shape{5, 2}})
      register_scenario("Chain",
                        std::string(Sync::kName) + "/" + std::string(Layout::kName) + "/masses" +
                            std::to_string(chain_shape.masses) + "/threads" + std::to_string(chain_shape.threads),
                        [chain_shape] {
                          const kernels::chain_model chain(kernels::chain_params::uniform(chain_shape.masses));
                          expect_bitwise_serial<Sync, Layout>(chain, chain_shape.threads, placement::none,
                                                              steps_for<Sync>(chain_shape.threads, kChainSteps));
                        });
  }
}

// Every primitive x every layout of the registries (sync/registry.hpp,
// layouts/registry.hpp): a new one joins the oracle by joining its registry.
const bool registered = [] {
  sync::for_each_primitive([]<class Sync>() {
    layouts::for_each_layout([]<class Layout>() {
      register_two_mass<Sync, Layout>();
      register_chain<Sync, Layout>();
    });
  });
  return true;
}();

}  // namespace
}  // namespace lockstep::testing::matrix
