// Long runs of the composed step (label stress): many thousand stages, so
// that a rare ordering (a producer several stages ahead of a consumer it does
// not depend on, a lost wake-up, back-pressure on a channel) gets its chance,
// still checked bit for bit against the serial RK4. Debug builds do a tenth.
//
// Every primitive of the registry runs twice: the paper's graph on 4 threads
// (a producer may lead a consumer it does not read by three stages; 4
// threads oversubscribe a 2-CPU machine) and a long chain (8 masses, 16
// equations, on 3 threads: uneven blocks of 6, 5, 5), each with the layout
// the rotation gives it (layout_rotation, matrix_cases.hpp: the applicable
// layout used least so far), so that every layout of the registry is
// stressed too. Primitives that spin long or lose wake-ups run the steps
// steps_for allows them (matrix_cases.hpp), not the full count.
#include "tests/matrix/matrix_cases.hpp"

namespace lockstep::testing::matrix {
namespace {

#if defined(NDEBUG)
constexpr std::uint64_t kScale = 10;
#else
constexpr std::uint64_t kScale = 1;
#endif

constexpr unsigned kPaperThreads = 4;
constexpr std::uint64_t kPaperSteps = 3000;
constexpr std::size_t kChainMasses = 8;
constexpr unsigned kChainThreads = 3;
constexpr std::uint64_t kChainSteps = 1500;

template <class Sync, class Layout>
void register_paper_graph() {
  register_scenario("MatrixStress", combination_name<Sync, Layout>(kPaperThreads, placement::none), [] {
    expect_bitwise_serial<Sync, Layout>(kernels::two_mass_model{}, kPaperThreads, placement::none,
                                        steps_for<Sync>(kPaperThreads, kPaperSteps * kScale));
  });
}

template <class Sync, class Layout>
void register_chain() {
  register_scenario("ChainStress",
                    std::string(Sync::kName) + "/" + std::string(Layout::kName) + "/masses" +
                        std::to_string(kChainMasses) + "/threads" + std::to_string(kChainThreads),
                    [] {
                      const kernels::chain_model chain(kernels::chain_params::uniform(kChainMasses));
                      expect_bitwise_serial<Sync, Layout>(chain, kChainThreads, placement::none,
                                                          steps_for<Sync>(kChainThreads, kChainSteps * kScale));
                    });
}

const bool registered = [] {
  layout_rotation rotation;
  sync::for_each_primitive([&rotation]<class Sync>() {
    with_layout<Sync>(rotation.next<Sync>(), []<class Layout>() { register_paper_graph<Sync, Layout>(); });
    with_layout<Sync>(rotation.next<Sync>(), []<class Layout>() { register_chain<Sync, Layout>(); });
  });
  cover_unused_layouts(rotation, []<class Sync>() { return true; },
                       []<class Sync, class Layout>() { register_paper_graph<Sync, Layout>(); });
  return true;
}();

}  // namespace
}  // namespace lockstep::testing::matrix
