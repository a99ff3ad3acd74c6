// The correctness oracle of the benchmark matrix (docs/design.md): every applicable
// sync x layout, on 1, 2 and 4 threads, unpinned and compact, reproduces the
// serial staged RK4 trajectory bit for bit; and the s-mass chain (blocks of
// whole masses, uneven ones, more threads than masses, three-way
// dependencies) on 1 to 4 threads, with every applicable layout, including
// the chains the harness integrates beyond four threads
// (kernels/model_choice.hpp). A combination that is not applicable is a test
// too: it must say why; so is a chain the threads cannot split.
#include "kernels/model_choice.hpp"
#include "tests/matrix/matrix_cases.hpp"

namespace lockstep::testing::matrix {
namespace {

// Paper's case: 300 steps (0.3 s, about one period of the slow mode).
constexpr std::uint64_t kPaperSteps = 300;
// Chains: fewer steps, more equations.
constexpr std::uint64_t kChainSteps = 120;
// A chain on more threads than CPUs (6, 8 and 16 threads on the 2-CPU
// development machine): every stage sync is then a round of context switches
// rather than of cache-line handoffs, so a few dozen steps (about a hundred
// stage syncs) keep these cases fast; long chain runs are the stress matrix's.
constexpr std::uint64_t kOversubscribedChainSteps = 24;

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
      // The rule (kernels/parallel_step.hpp): only a dataflow channel with a
      // shared layout is left out, and its reason names the layouts that do
      // apply, so that a user who reads it knows what to run instead.
      EXPECT_EQ(Sync::kKind, sync::primitive_kind::channel);
      EXPECT_EQ(Layout::kKind, layouts::layout_kind::shared);
      const std::string reason(kernels::applicable<Sync, Layout>().reason);
      layouts::for_each_layout([&reason]<class Other>() {
        if constexpr (kernels::applicable<Sync, Other>().applicable) {
          EXPECT_NE(reason.find(Other::kName), std::string::npos) << "the reason does not name " << Other::kName
                                                                  << ", which applies: " << reason;
        }
      });
      // Not applicable whatever the threads: the runtime conditions come after.
      EXPECT_EQ((kernels::not_applicable_reason<Sync, Layout>(4, 8)), reason);
    });
  }
}

// Chains, with every applicable layout (the paper's four equations split
// evenly on 1, 2 and 4 threads; a layout's offsets for uneven blocks are
// checked here). A chain is cut between masses when there are at least as
// many masses as threads (layouts/partition.hpp), so each block is whole
// masses, computes its own positions and velocities and reads its
// neighbours' boundary positions:
//   5 masses on 2 threads: 3 + 2 masses; on 3 threads: 2 + 2 + 1 (threads
//   not dividing masses); 8 on 3: 3 + 3 + 2; 33 on 4: 9 + 8 + 8 + 8 (the
//   middle-mass loop over several masses, two neighbours each); 4 on 4: one
//   mass each; 6 on 1: the whole chain, nobody to wait for.
// With more threads than masses the blocks are single equations, so a mass's
// position and velocity can have two owners: 3 masses on 4 threads gives
// {x1, v1}, {x2, v2}, {x3}, {v3}; 2 masses on 3 threads {x1, v1}, {x2}, {v2}.
template <class Sync, class Layout>
void register_chain() {
  if constexpr (kernels::applicable<Sync, Layout>().applicable) {
    struct shape {
      std::size_t masses;
      unsigned threads;
    };
    for (const shape chain_shape : {shape{5, 2}, shape{5, 3}, shape{8, 3}, shape{33, 4}, shape{4, 4}, shape{6, 1},
                                    shape{3, 4}, shape{2, 3}})
      register_scenario("Chain", chain_name<Sync, Layout>(chain_shape.masses, chain_shape.threads),
                        [chain_shape] {
                          const kernels::chain_model chain(kernels::chain_params::uniform(chain_shape.masses));
                          expect_bitwise_serial<Sync, Layout>(chain, chain_shape.threads, placement::none,
                                                              steps_for<Sync>(chain_shape.threads, kChainSteps));
                        });
  }
}

// More threads than a chain's equations (T > 2S) is refused with a reason,
// before anything is built, for every applicable pair.
template <class Sync, class Layout>
void register_refused_chain() {
  if constexpr (kernels::applicable<Sync, Layout>().applicable) {
    register_scenario("Chain", std::string(Sync::kName) + "/" + std::string(Layout::kName) + "/masses2/threads5/refused",
                      [] {
                        const kernels::chain_model chain(kernels::chain_params::uniform(2));
                        EXPECT_NE((kernels::not_applicable_reason<Sync, Layout>(chain.equations(), 5))
                                      .find("every thread must own at least one equation"),
                                  std::string::npos);
                        EXPECT_THROW((kernels::parallel_rk4<Sync, Layout, kernels::chain_model>(chain, kStepSize, 5)),
                                     layouts::partition_error);
                      });
  }
}

// The chains the harness integrates beyond four threads: kernels::model_for's
// default model on 6, 8 and 16 threads (chains of 3, 4 and 8 masses, one
// equation per thread; a dataflow participant waits only for the few
// participants whose equations it reads), as `lockstep run --threads 16`
// measures them. Threads outnumber the CPUs here (2), the regime in which the
// harness bounds and flags the primitives that stall, so each case runs few
// steps (kOversubscribedChainSteps), and steps_for cuts the primitives that
// spin long to 3 steps (12 stage syncs).
constexpr unsigned kDefaultChainThreads[] = {6, 8, 16};

template <class Sync, class Layout>
void register_default_chain(unsigned threads) {
  const kernels::model_choice model = kernels::model_for(threads);
  register_scenario("Chain", chain_name<Sync, Layout>(model.masses, threads), [threads, model] {
    // The harness measures this combination (an empty reason): the default
    // model gives every thread an equation.
    ASSERT_EQ((kernels::not_applicable_reason<Sync, Layout>(model.equations(), threads)), "");
    const std::uint64_t base = threads > cpu_count() ? kOversubscribedChainSteps : kChainSteps;
    expect_bitwise_serial<Sync, Layout>(kernels::chain_model(model.chain()), threads, placement::none,
                                        steps_for<Sync>(threads, base));
  });
}

// Every primitive runs these shapes with every applicable layout, except the
// pure-spin barriers (primitive_info::pure_spin: the ck ones), which take one
// layout per shape, rotating (layout_rotation, matrix_cases.hpp) so that
// between them they use every layout. With more threads than CPUs they
// progress only as the scheduler preempts a spinner, about a timeslice per
// phase: even bounded to 3 steps a case takes about a second here (up to 2.3 s
// at 16 threads, measured on the 2-vCPU development VM), and every layout
// would be 60 such cases, 97 % of these shapes' time. What a layout adds at
// these shapes (blocks of one equation each) is the same with every barrier,
// and each layout runs them with every primitive that is not pure spin. Every
// case stays well inside expect_bitwise_serial's watchdog; none is skipped.
template <class Sync>
constexpr bool pure_spin() {
  return sync::info_of<Sync>().pure_spin;
}

// Every primitive x every layout of the registries (sync/registry.hpp,
// layouts/registry.hpp): a new one joins the oracle by joining its registry.
const bool registered = [] {
  layout_rotation pure_spin_layouts;
  sync::for_each_primitive([&pure_spin_layouts]<class Sync>() {
    layouts::for_each_layout([]<class Layout>() {
      register_two_mass<Sync, Layout>();
      register_chain<Sync, Layout>();
      register_refused_chain<Sync, Layout>();
      if constexpr (kernels::applicable<Sync, Layout>().applicable && !pure_spin<Sync>())
        for (const unsigned threads : kDefaultChainThreads) register_default_chain<Sync, Layout>(threads);
    });
    if constexpr (pure_spin<Sync>())
      for (const unsigned threads : kDefaultChainThreads)
        with_layout<Sync>(pure_spin_layouts.next<Sync>(),
                          [threads]<class Layout>() { register_default_chain<Sync, Layout>(threads); });
  });
  return true;
}();

}  // namespace
}  // namespace lockstep::testing::matrix
