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
//                                       (per_thread): results go
//                                       to the private copy and the board; after
//                                       each stage's barrier a participant copies
//                                       its dependencies in from the board.
//   channel_copy_in<Channel, Layout>    a dataflow channel (seqlock, spsc_queue)
//                                       and a private_copy layout (per_thread):
//                                       the owner publishes its
//                                       block from its private copy; a consumer
//                                       receives from the producers its block
//                                       depends on, straight into its private copy.
//
// Every adapter offers the same members to the step, for participant p:
//   states(p, parity)            x_n as a stage_values accessor
//   stage_values(p, s)           k_s as a stage_values accessor (s in 0..2 for inputs)
//   own_stage_value(p, s, i)     k_{s,i} of an equation p owns (s in 0..3)
//   write_stage_value(p, s, i, v), write_next_state(p, parity, i, v)
//   publish(p, self, stage)      after p wrote its block's values of `stage`
//   wait(p, self, stage)         the stage sync (what instrumentation times)
//   copy_in(p, stage)            after the sync: whatever p must copy before the next stage
//   final_state(parity, i)       x_i after the team joined
// Constructors take the partition, the plans, and any further arguments for
// the primitive's constructor (after the participant count or the graph and
// width), e.g. win_event_faithful's timeout.
// `stage` in publish/wait is the global stage number, step * 4 + s, which the
// channels require to increase by one per call.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "kernels/oscillator.hpp"
#include "layouts/aligned_buffer.hpp"
#include "layouts/partition.hpp"
#include "layouts/per_thread.hpp"  // the board's slot numbering (kBoardNextState) every private_copy layout shares
#include "layouts/shared_slots.hpp"
#include "platform/cache_line.hpp"
#include "sync/concepts.hpp"

namespace lockstep::kernels {

// What one participant reads from others: computed once from the model.
struct participant_plan {
  layouts::equation_block block;
  std::vector<std::size_t> dependencies;  // equations outside the block its equations read, ascending
  std::vector<unsigned> producers;        // owners of those equations, ascending
  bool has_consumers = false;             // some other participant reads one of its equations
};

// Every participant's plan, for a model split into `blocks`: the one place
// that derives who reads whom (the threaded step and the MPI ranks of
// distributed/ both ask here). Not on the measured path (allocates).
template <oscillator_model Model>
[[nodiscard]] std::vector<participant_plan> plan_participants(const Model& model, const layouts::partition& blocks) {
  std::vector<participant_plan> plans(blocks.participants());
  for (unsigned participant = 0; participant < blocks.participants(); ++participant) {
    participant_plan& entry = plans[participant];
    entry.block = blocks.block(participant);
    entry.dependencies = block_dependencies(model, entry.block.first, entry.block.last);
    for (std::size_t equation : entry.dependencies) entry.producers.push_back(blocks.owner(equation));
    std::sort(entry.producers.begin(), entry.producers.end());
    entry.producers.erase(std::unique(entry.producers.begin(), entry.producers.end()), entry.producers.end());
  }
  for (const participant_plan& consumer : plans)
    for (unsigned producer : consumer.producers) plans[producer].has_consumers = true;
  return plans;
}

// ---------------------------------------------------------------------------
template <class Barrier, class Layout>
class barrier_in_place {
 public:
  using sync_type = Barrier;

  template <class... SyncArgs>
  barrier_in_place(const layouts::partition& blocks, const std::vector<participant_plan>& /*plans*/,
                   SyncArgs&&... sync_args)
      : layout_(blocks), barrier_(blocks.participants(), std::forward<SyncArgs>(sync_args)...) {
    last_stage_.reserve(blocks.participants());
    for (unsigned participant = 0; participant < blocks.participants(); ++participant)
      last_stage_.emplace_back(blocks.equations(), platform::kCacheLine);
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

  double own_stage_value(unsigned participant, unsigned stage, std::size_t equation) noexcept {
    return stage < layouts::kSharedStageSlots ? layout_.stage(stage, equation) : last_stage_[participant][equation];
  }
  void write_stage_value(unsigned participant, unsigned stage, std::size_t equation, double value) noexcept {
    if (stage < layouts::kSharedStageSlots)
      layout_.stage(stage, equation) = value;
    else
      last_stage_[participant][equation] = value;  // k_3: nobody else reads it
  }
  void write_next_state(unsigned /*participant*/, unsigned parity, std::size_t equation, double value) noexcept {
    layout_.state(parity ^ 1U, equation) = value;
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
  Layout layout_;
  Barrier barrier_;
  std::vector<layouts::aligned_buffer> last_stage_;  // per participant, k_3 (private, own lines)
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
  double own_stage_value(unsigned participant, unsigned stage, std::size_t equation) noexcept {
    return layout_.private_stage(participant, stage)[equation];
  }
  void write_stage_value(unsigned participant, unsigned stage, std::size_t equation, double value) noexcept {
    layout_.private_stage(participant, stage)[equation] = value;
    if (stage < layouts::kSharedStageSlots) layout_.board(stage, equation) = value;
  }
  void write_next_state(unsigned participant, unsigned /*parity*/, std::size_t equation, double value) noexcept {
    layout_.private_state(participant)[equation] = value;
    layout_.board(layouts::kBoardNextState, equation) = value;
  }
  void write_initial_state(std::size_t equation, double value) noexcept {
    for (unsigned participant = 0; participant < blocks_.participants(); ++participant)
      layout_.private_state(participant)[equation] = value;
  }

  void publish(unsigned /*participant*/, sync::participant& /*self*/, std::uint64_t /*stage*/) noexcept {}
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
        width_(blocks.largest_block()),
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
  double own_stage_value(unsigned participant, unsigned stage, std::size_t equation) noexcept {
    return layout_.private_stage(participant, stage)[equation];
  }
  void write_stage_value(unsigned participant, unsigned stage, std::size_t equation, double value) noexcept {
    layout_.private_stage(participant, stage)[equation] = value;
  }
  void write_next_state(unsigned participant, unsigned /*parity*/, std::size_t equation, double value) noexcept {
    layout_.private_state(participant)[equation] = value;
  }
  void write_initial_state(std::size_t equation, double value) noexcept {
    for (unsigned participant = 0; participant < blocks_.participants(); ++participant)
      layout_.private_state(participant)[equation] = value;
  }

  // What a participant publishes at stage s: k_s of its block for s = 0..2,
  // x_{n+1} of its block at s = 3 (the values its consumers read next).
  void publish(unsigned participant, sync::participant& self, std::uint64_t stage) {
    const participant_plan& plan = (*plans_)[participant];
    if (!plan.has_consumers) return;  // nobody would receive it (one thread, or an unread block)
    const double* source = block_values(participant, static_cast<unsigned>(stage % 4)) + plan.block.first;
    if (plan.block.size() != width_) {
      // A smaller block than the channel's width travels in a full-width
      // message; the tail is never read by a consumer.
      double* const staging = staging_[participant].data();
      std::copy(source, source + plan.block.size(), staging);
      source = staging;
    }
    channel_.publish(self, stage, std::span<const double>(source, width_));
  }
  // Waits only for the producers this block depends on; the channel copies
  // each one's block into this participant's private copy.
  void wait(unsigned participant, sync::participant& self, std::uint64_t stage) {
    double* const destination = block_values(participant, static_cast<unsigned>(stage % 4));
    for (unsigned producer : (*plans_)[participant].producers) {
      const layouts::equation_block block = blocks_.block(producer);
      if (block.size() == width_) {
        channel_.receive(self, producer, stage, std::span<double>(destination + block.first, width_));
      } else {
        double* const staging = staging_[participant].data();
        channel_.receive(self, producer, stage, std::span<double>(staging, width_));
        std::copy(staging, staging + block.size(), destination + block.first);
      }
    }
  }
  void copy_in(unsigned /*participant*/, unsigned /*stage*/) noexcept {}

  double final_state(unsigned /*parity*/, std::size_t equation) noexcept {
    return layout_.private_state(blocks_.owner(equation))[equation];
  }

 private:
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
  std::size_t width_;           // doubles per message: the largest block (the channel's contract)
  Channel channel_;
  const std::vector<participant_plan>* plans_;
  std::vector<layouts::aligned_buffer> staging_;  // per participant, for blocks smaller than width_
};

}  // namespace lockstep::kernels
