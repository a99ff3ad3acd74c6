// Long runs of the composed step (label stress): many thousand stages, so
// that a rare ordering (a producer several stages ahead of a consumer it does
// not depend on, a lost wake-up, back-pressure on a channel) gets its chance,
// still checked bit for bit against the serial RK4. Debug builds do a tenth.
#include "tests/matrix/matrix_cases.hpp"

namespace lockstep::testing::matrix {
namespace {

#if defined(NDEBUG)
constexpr std::uint64_t kScale = 10;
#else
constexpr std::uint64_t kScale = 1;
#endif

template <class Sync, class Layout>
void stress(unsigned threads, std::uint64_t steps) {
  expect_bitwise_serial<Sync, Layout>(kernels::two_mass_model{}, threads, placement::none, steps * kScale);
}

template <class Sync, class Layout>
void stress_chain(std::size_t masses, unsigned threads, std::uint64_t steps) {
  const kernels::chain_model chain(kernels::chain_params::uniform(masses));
  expect_bitwise_serial<Sync, Layout>(chain, threads, placement::none, steps * kScale);
}

// The dataflow graphs: the paper's (a producer may lead a consumer it does
// not read by three stages) and a long chain (16 equations, blocks of 4).
TEST(MatrixStress, SeqlockPapersGraph) { stress<sync::seqlock, layouts::per_thread>(4, 3000); }
TEST(MatrixStress, SpscQueuePapersGraph) { stress<sync::spsc_queue, layouts::per_thread>(4, 3000); }
TEST(MatrixStress, SeqlockChain) { stress_chain<sync::seqlock, layouts::per_thread>(8, 4, 1500); }
TEST(MatrixStress, SpscQueueChain) { stress_chain<sync::spsc_queue, layouts::per_thread>(8, 3, 1500); }
// The blocking barriers, in place and with copy-in.
TEST(MatrixStress, FutexSpinPacked) { stress<sync::futex_spin, layouts::packed>(4, 3000); }
TEST(MatrixStress, StdBarrierPerThread) { stress<sync::std_barrier, layouts::per_thread>(4, 3000); }
TEST(MatrixStress, WinEventPadded128) { stress<sync::win_event, layouts::padded128>(4, 3000); }
TEST(MatrixStress, PthreadBarrierChain) { stress_chain<sync::pthread_barrier, layouts::padded64>(8, 4, 1500); }

}  // namespace
}  // namespace lockstep::testing::matrix
