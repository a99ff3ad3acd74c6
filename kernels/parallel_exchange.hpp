#pragma once
// How the composed RK4 step (parallel_step.hpp) moves values between its
// participants: one small adapter per way of combining a synchronisation
// primitive with a layout, so that the step's loop is one body for all of
// them and never branches on the primitive.
//
//   barrier_in_place<Barrier, Layout>   a phase_barrier and a shared layout
//                                       (packed, padded64, padded128): operands
//                                       read in place, results written in place,
//                                       every participant arrives at every stage.
//   barrier_copy_in<Barrier, Layout>    a phase_barrier and a private_copy layout
//                                       (per_thread): results go to the private
//                                       copy; publish() puts the values other
//                                       participants read (the block's exports)
//                                       on the board; after each stage's barrier
//                                       a participant copies its dependencies in
//                                       from the board.
//   channel_copy_in<Channel, Layout>    a dataflow channel (seqlock, spsc_queue,
//                                       mailbox) and a private_copy layout
//                                       (per_thread): the owner publishes its
//                                       block's exports from its private copy; a
//                                       consumer receives from the producers its
//                                       block depends on, straight into its
//                                       private copy.
//
// Every adapter offers the same members to the step, for participant p (the
// own_* pointers address p's block: element i is equation block.first + i,
// one array per slot, no per-equation lookup; layouts/shared_slots.hpp):
//   own_states(p, parity)        x_n of p's block
//   own_next_states(p, parity)   where p writes x_{n+1} of its block
//   own_stage_values(p, s)       k_s of p's block, s in 0..3 (written at stage s)
//   states(p, parity)            x_n as a stage_values accessor by equation (dependencies)
//   stage_values(p, s)           k_s as a stage_values accessor by equation (s in 0..2)
//   publish(p, self, stage)      after p wrote its block's values of `stage`
//   wait(p, self, stage)         the stage sync (what instrumentation times)
//   copy_in(p, stage)            after the sync: whatever p must copy before the next stage
//   final_state(parity, i)       x_i after the team joined
// Constructors take the partition, the plans, and any further arguments for
// the primitive's constructor (after the participant count or the graph and
// width), e.g. win_event_faithful's timeout.
// `stage` in publish/wait is the global stage number, step * 4 + s, which the
// channels require to increase by one per call.
//
// What travels: a participant's exports (participant_plan), the equations of
// its block that some other participant reads, and nothing else. For the
// paper's two masses that is the whole block (every equation is read by
// another thread); for a chain cut between masses it is the positions at the
// block's two ends, one double to each neighbour per stage, whatever the
// chain's length.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "kernels/oscillator.hpp"
#include "kernels/rk4.hpp"
#include "layouts/aligned_buffer.hpp"
#include "layouts/partition.hpp"
#include "layouts/per_thread.hpp"  // the board's slot numbering (kBoardNextState) every private_copy layout shares
#include "layouts/shared_slots.hpp"
#include "platform/cache_line.hpp"
#include "sync/concepts.hpp"

namespace lockstep::kernels {

// What one participant reads from others and gives them: computed once from
// the model.
struct participant_plan {
  layouts::equation_block block;
  std::vector<std::size_t> dependencies;  // equations outside the block its equations read, ascending
  std::vector<unsigned> producers;        // owners of those equations, ascending
  std::vector<std::size_t> exports;       // equations of its block some other participant reads, ascending
  bool exports_contiguous = false;        // exports are one run of consecutive equations
  bool has_consumers = false;             // exports is not empty
  // The smallest run of the block holding every equation of the block that
  // the block itself reads (empty, first == last, when it reads none: the
  // paper's split, where every equation reads other threads' values): the
  // stage inputs the step computes from its own values.
  layouts::equation_block own_reads;
};

// The partition a model is split by on `participants`: its equations in
// blocks of its block_grain() (layouts/partition.hpp), so a chain is cut
// between masses and the paper's two masses one equation at a time.
template <oscillator_model Model>
[[nodiscard]] layouts::partition partition_of(const Model& model, unsigned participants) {
  return layouts::partition(model.equations(), participants, model.block_grain());
}

// Every participant's plan, for a model split into `blocks`: the one place
// that derives who reads whom (the threaded step and the MPI ranks of
// distributed/ both ask here). Not on the measured path (allocates).
template <oscillator_model Model>
[[nodiscard]] std::vector<participant_plan> plan_participants(const Model& model, const layouts::partition& blocks) {
  std::vector<participant_plan> plans(blocks.participants());
  std::vector<bool> exported(blocks.equations(), false);
  for (unsigned participant = 0; participant < blocks.participants(); ++participant) {
    participant_plan& entry = plans[participant];
    entry.block = blocks.block(participant);
    entry.dependencies = block_dependencies(model, entry.block.first, entry.block.last);
    for (std::size_t equation : entry.dependencies) {
      entry.producers.push_back(blocks.owner(equation));
      exported[equation] = true;
    }
    std::sort(entry.producers.begin(), entry.producers.end());
    entry.producers.erase(std::unique(entry.producers.begin(), entry.producers.end()), entry.producers.end());
    std::size_t own_first = entry.block.last;
    std::size_t own_last = entry.block.first;
    for (std::size_t equation = entry.block.first; equation < entry.block.last; ++equation)
      for (std::size_t dependency : model.dependencies(equation))
        if (entry.block.contains(dependency)) {
          own_first = std::min(own_first, dependency);
          own_last = std::max(own_last, dependency + 1);
        }
    entry.own_reads = own_first < own_last ? layouts::equation_block{own_first, own_last}
                                           : layouts::equation_block{entry.block.first, entry.block.first};
  }
  for (participant_plan& entry : plans) {
    for (std::size_t equation = entry.block.first; equation < entry.block.last; ++equation)
      if (exported[equation]) entry.exports.push_back(equation);
    entry.has_consumers = !entry.exports.empty();
    entry.exports_contiguous =
        entry.has_consumers && entry.exports.back() - entry.exports.front() + 1 == entry.exports.size();
  }
  return plans;
}

// The most values one participant exports: the width of a channel message.
[[nodiscard]] inline std::size_t largest_exports(const std::vector<participant_plan>& plans) noexcept {
  std::size_t largest = 0;
  for (const participant_plan& plan : plans) largest = std::max(largest, plan.exports.size());
  return largest;
}

// ---------------------------------------------------------------------------
template <class Barrier, class Layout>
class barrier_in_place {
 public:
  using sync_type = Barrier;

  template <class... SyncArgs>
  barrier_in_place(const layouts::partition& blocks, const std::vector<participant_plan>& plans,
                   SyncArgs&&... sync_args)
      : layout_(blocks), barrier_(blocks.participants(), std::forward<SyncArgs>(sync_args)...), plans_(&plans) {
    last_stage_.reserve(blocks.participants());
    for (unsigned participant = 0; participant < blocks.participants(); ++participant)
      last_stage_.emplace_back(blocks.block(participant).size(), platform::kCacheLine);
  }

  struct state_reader {
    Layout* layout;
    unsigned parity;
    double operator[](std::size_t equation) const noexcept { return layout->state(parity, equation); }
  };
  struct stage_reader {
    Layout* layout;
    unsigned stage;
    double operator[](std::size_t equation) const noexcept { return layout->stage(stage, equation); }
  };

  state_reader states(unsigned /*participant*/, unsigned parity) noexcept { return {&layout_, parity}; }
  stage_reader stage_values(unsigned /*participant*/, unsigned stage) noexcept { return {&layout_, stage}; }

  const double* own_states(unsigned participant, unsigned parity) noexcept {
    return &layout_.state(parity, first_of(participant));
  }
  double* own_next_states(unsigned participant, unsigned parity) noexcept {
    return &layout_.state(parity ^ 1U, first_of(participant));
  }
  double* own_stage_values(unsigned participant, unsigned stage) noexcept {
    // k_3 stays private: nobody else reads it.
    return stage < layouts::kSharedStageSlots ? &layout_.stage(stage, first_of(participant))
                                              : last_stage_[participant].data();
  }
  void write_initial_state(std::size_t equation, double value) noexcept { layout_.state(0, equation) = value; }

  void publish(unsigned /*participant*/, sync::participant& /*self*/, std::uint64_t /*stage*/) noexcept {}
  // The barrier orders every write of this stage before every read of the
  // next (phase_barrier's memory-ordering contract).
  void wait(unsigned /*participant*/, sync::participant& self, std::uint64_t /*stage*/) {
    barrier_.arrive_and_wait(self);
  }
  void copy_in(unsigned /*participant*/, unsigned /*stage*/) noexcept {}

  double final_state(unsigned parity, std::size_t equation) noexcept { return layout_.state(parity, equation); }

 private:
  std::size_t first_of(unsigned participant) const noexcept { return (*plans_)[participant].block.first; }

  Layout layout_;
  Barrier barrier_;
  const std::vector<participant_plan>* plans_;
  std::vector<layouts::aligned_buffer> last_stage_;  // per participant, k_3 of its block (private, own lines)
};

// ---------------------------------------------------------------------------
template <class Barrier, class Layout>
class barrier_copy_in {
 public:
  using sync_type = Barrier;

  template <class... SyncArgs>
  barrier_copy_in(const layouts::partition& blocks, const std::vector<participant_plan>& plans,
                  SyncArgs&&... sync_args)
      : blocks_(blocks),
        layout_(blocks),
        barrier_(blocks.participants(), std::forward<SyncArgs>(sync_args)...),
        plans_(&plans) {}

  const double* states(unsigned participant, unsigned /*parity*/) noexcept {
    return layout_.private_state(participant);
  }
  const double* stage_values(unsigned participant, unsigned stage) noexcept {
    return layout_.private_stage(participant, stage);
  }
  const double* own_states(unsigned participant, unsigned /*parity*/) noexcept {
    return layout_.private_state(participant) + first_of(participant);
  }
  // x_{n+1} overwrites x_n in the private copy, element by element after its
  // own read (the update reads only its own element).
  double* own_next_states(unsigned participant, unsigned /*parity*/) noexcept {
    return layout_.private_state(participant) + first_of(participant);
  }
  double* own_stage_values(unsigned participant, unsigned stage) noexcept {
    return layout_.private_stage(participant, stage) + first_of(participant);
  }
  void write_initial_state(std::size_t equation, double value) noexcept {
    for (unsigned participant = 0; participant < blocks_.participants(); ++participant)
      layout_.private_state(participant)[equation] = value;
  }

  // The exports of this stage, from the private copy to the board.
  void publish(unsigned participant, sync::participant& /*self*/, std::uint64_t stage) noexcept {
    const auto stage_in_step = static_cast<unsigned>(stage % kRk4Stages);
    const bool next_state = stage_in_step >= layouts::kSharedStageSlots;
    const double* const source =
        next_state ? layout_.private_state(participant) : layout_.private_stage(participant, stage_in_step);
    const std::size_t slot = next_state ? layouts::kBoardNextState : stage_in_step;
    for (std::size_t equation : (*plans_)[participant].exports) layout_.board(slot, equation) = source[equation];
  }
  // The barrier orders the board writes of this stage before the copy-in below.
  void wait(unsigned /*participant*/, sync::participant& self, std::uint64_t /*stage*/) {
    barrier_.arrive_and_wait(self);
  }
  // X1 = GX1: only the equations this participant's block reads.
  void copy_in(unsigned participant, unsigned stage) noexcept {
    double* const destination = stage < layouts::kSharedStageSlots ? layout_.private_stage(participant, stage)
                                                                   : layout_.private_state(participant);
    const std::size_t slot = stage < layouts::kSharedStageSlots ? stage : layouts::kBoardNextState;
    for (std::size_t equation : (*plans_)[participant].dependencies)
      destination[equation] = layout_.board(slot, equation);
  }

  double final_state(unsigned /*parity*/, std::size_t equation) noexcept {
    return layout_.private_state(blocks_.owner(equation))[equation];
  }

 private:
  std::size_t first_of(unsigned participant) const noexcept { return (*plans_)[participant].block.first; }

  layouts::partition blocks_;
  Layout layout_;  // a private_copy layout: the private copies and the board
  Barrier barrier_;
  const std::vector<participant_plan>* plans_;
};

// ---------------------------------------------------------------------------
template <class Channel, class Layout>
class channel_copy_in {
 public:
  using sync_type = Channel;

  template <class... SyncArgs>
  channel_copy_in(const layouts::partition& blocks, const std::vector<participant_plan>& plans,
                  SyncArgs&&... sync_args)
      : blocks_(blocks),
        layout_(blocks),
        width_(std::max<std::size_t>(largest_exports(plans), 1)),
        channel_(graph_of(plans), width_, std::forward<SyncArgs>(sync_args)...),
        plans_(&plans) {
    staging_.reserve(blocks.participants());
    for (unsigned participant = 0; participant < blocks.participants(); ++participant)
      staging_.emplace_back(width_, platform::kCacheLine);
  }

  const double* states(unsigned participant, unsigned /*parity*/) noexcept {
    return layout_.private_state(participant);
  }
  const double* stage_values(unsigned participant, unsigned stage) noexcept {
    return layout_.private_stage(participant, stage);
  }
  const double* own_states(unsigned participant, unsigned /*parity*/) noexcept {
    return layout_.private_state(participant) + first_of(participant);
  }
  // In place, as barrier_copy_in.
  double* own_next_states(unsigned participant, unsigned /*parity*/) noexcept {
    return layout_.private_state(participant) + first_of(participant);
  }
  double* own_stage_values(unsigned participant, unsigned stage) noexcept {
    return layout_.private_stage(participant, stage) + first_of(participant);
  }
  void write_initial_state(std::size_t equation, double value) noexcept {
    for (unsigned participant = 0; participant < blocks_.participants(); ++participant)
      layout_.private_state(participant)[equation] = value;
  }

  // What a participant publishes at stage s: its exports' k_s for s = 0..2,
  // their x_{n+1} at s = 3 (the values its consumers read next).
  void publish(unsigned participant, sync::participant& self, std::uint64_t stage) {
    const participant_plan& plan = (*plans_)[participant];
    if (!plan.has_consumers) return;  // nobody would receive it (one thread, or an unread block)
    const double* const values = block_values(participant, static_cast<unsigned>(stage % kRk4Stages));
    if (plan.exports_contiguous && plan.exports.size() == width_) {
      channel_.publish(self, stage, std::span<const double>(values + plan.exports.front(), width_));
      return;
    }
    // Exports that are not one full-width run travel gathered in a
    // full-width message; the tail is never read by a consumer.
    double* const staging = staging_[participant].data();
    for (std::size_t index = 0; index < plan.exports.size(); ++index) staging[index] = values[plan.exports[index]];
    channel_.publish(self, stage, std::span<const double>(staging, width_));
  }
  // Waits only for the producers this block depends on; the channel copies
  // each one's exports into this participant's private copy.
  void wait(unsigned participant, sync::participant& self, std::uint64_t stage) {
    double* const destination = block_values(participant, static_cast<unsigned>(stage % kRk4Stages));
    for (unsigned producer : (*plans_)[participant].producers) {
      const participant_plan& from = (*plans_)[producer];
      if (from.exports_contiguous && from.exports.size() == width_) {
        channel_.receive(self, producer, stage, std::span<double>(destination + from.exports.front(), width_));
      } else {
        double* const staging = staging_[participant].data();
        channel_.receive(self, producer, stage, std::span<double>(staging, width_));
        for (std::size_t index = 0; index < from.exports.size(); ++index)
          destination[from.exports[index]] = staging[index];
      }
    }
  }
  void copy_in(unsigned /*participant*/, unsigned /*stage*/) noexcept {}

  double final_state(unsigned /*parity*/, std::size_t equation) noexcept {
    return layout_.private_state(blocks_.owner(equation))[equation];
  }

 private:
  std::size_t first_of(unsigned participant) const noexcept { return (*plans_)[participant].block.first; }
  double* block_values(unsigned participant, unsigned stage_in_step) noexcept {
    return stage_in_step < layouts::kSharedStageSlots ? layout_.private_stage(participant, stage_in_step)
                                                      : layout_.private_state(participant);
  }
  static sync::dependency_graph graph_of(const std::vector<participant_plan>& plans) {
    sync::dependency_graph graph;
    graph.producers_of.reserve(plans.size());
    for (const participant_plan& plan : plans) graph.producers_of.push_back(plan.producers);
    return graph;
  }

  layouts::partition blocks_;
  Layout layout_;  // a private_copy layout; only its private copies are used: the channel is the board
  std::size_t width_;           // doubles per message: the most exports of a producer (the channel's contract)
  Channel channel_;
  const std::vector<participant_plan>* plans_;
  std::vector<layouts::aligned_buffer> staging_;  // per participant, for exports that are not one full-width run
};

}  // namespace lockstep::kernels
