#pragma once
// shm_window: when every rank runs on one host, the ranks share one MPI-3
// shared-memory window (MPI_Win_allocate_shared) and synchronise through it
// with lockstep's own futex_spin barrier, built for processes
// (sync::process_shared_futex_spin: the same protocol, its slots inline, its
// futexes the shared kind). No message moves: the stage values are read in
// place, as the threaded step's barrier with the packed layout reads them.
//
// The window (rank 0 allocates it, the others map it with
// MPI_Win_shared_query):
//     slack, the barrier on its alignment, then (from the next cache line)
//     x[2][n], k[3][n] doubles
// The slack: a window's base is not aligned for the barrier (Open MPI 4.1
// hands out bases 8 bytes past a page), so the barrier goes where
// distributed/shared_window_layout.hpp rounds it up to, the same offset in
// every rank.
// x has two parities (a rank writes x_{n+1} while a slower one may still read
// x_n); k_3 stays private to the step.
// Contract (exchange.hpp): share(g) is one arrive_and_wait: every rank's
// writes of stage g happen-before every read after it (futex_spin's ordering
// contract, which holds across processes: the words are lock-free atomics in
// coherent shared memory).
// Applicability: every rank on one host; at most the barrier's
// kSharedParticipantsMax ranks.
//
// shm_mailbox_exchange: the same window, with lockstep's dataflow mailbox
// across processes instead (sync::process_shared_mailbox: its rings, received
// rows and census in the window, shared futexes): each rank publishes its
// block and receives only the blocks it reads, into private copies, as the
// threaded step's channel_copy_in does. The mailbox's stage numbers never
// restart: reset() continues them where the last run stopped.
#include <memory>
#include <span>
#include <vector>

#include "distributed/exchange.hpp"
#include "sync/futex_spin.hpp"
#include "sync/mailbox.hpp"

namespace lockstep::distributed {

class shm_window_exchange final : public exchange {
 public:
  explicit shm_window_exchange(const exchange_setup& setup);
  ~shm_window_exchange() override;
  shm_window_exchange(const shm_window_exchange&) = delete;
  shm_window_exchange& operator=(const shm_window_exchange&) = delete;

  const double* state(unsigned parity) override { return values_ + parity * equations_; }
  double* next_state(unsigned parity) override { return values_ + (parity ^ 1U) * equations_; }
  double* stage(unsigned stage) override { return values_ + (2 + stage) * equations_; }
  void share(std::uint64_t global_stage) override;
  void reset(std::span<const double> initial) override;
  [[nodiscard]] sync::sync_counters counters() const override { return self_.counters; }

 private:
  MPI_Comm comm_;
  std::size_t equations_;
  MPI_Win window_ = MPI_WIN_NULL;
  sync::process_shared_futex_spin* barrier_ = nullptr;
  double* values_ = nullptr;
  sync::participant self_{};
};

class shm_mailbox_exchange final : public private_copies {
 public:
  explicit shm_mailbox_exchange(const exchange_setup& setup);
  ~shm_mailbox_exchange() override;
  shm_mailbox_exchange(const shm_mailbox_exchange&) = delete;
  shm_mailbox_exchange& operator=(const shm_mailbox_exchange&) = delete;

  void share(std::uint64_t global_stage) override;
  void reset(std::span<const double> initial) override;
  [[nodiscard]] sync::sync_counters counters() const override { return self_.counters; }

 private:
  MPI_Comm comm_;
  std::size_t own_first_;
  std::size_t own_count_;
  bool has_consumers_;
  std::size_t width_;  // doubles per message: the largest block (the channel's contract)
  std::vector<producer_block> producers_;
  std::vector<double> staging_;  // for blocks smaller than width_
  MPI_Win window_ = MPI_WIN_NULL;
  std::unique_ptr<sync::process_shared_mailbox> channel_;
  std::uint64_t first_stage_ = 0;  // the channel's stage of global stage 0 in this run
  std::uint64_t next_stage_ = 0;   // the channel's next stage
  sync::participant self_{};
};

}  // namespace lockstep::distributed
