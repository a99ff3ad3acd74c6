#pragma once
// The one ranking of a run's entries, which every section reads: the
// summary's tables, the answer's choices, the JSON's lockstep_rankings, the
// paired comparisons' plan and the crossover's baseline.
//
// An entry counts when it measured its time without error and did not
// collapse (paired_blocks.hpp: find_collapsed); its figure is the median over
// repetitions of its time per unit (entry_spec::time_counter: a step or an
// episode). A group is one thread count, model and placement; groups come in
// numeric thread order, then by model (the paper's two masses first, then
// chains by size) and placement name; within a group, fastest first (equal
// medians keep the book's order).
#include <vector>

#include "bench/results/entry_spec.hpp"
#include "bench/run/run_book.hpp"
#include "kernels/model_choice.hpp"
#include "platform/placement.hpp"

namespace lockstep::bench {

// An entry that measured its time, with its median over repetitions.
struct measured_entry {
  const captured_entry* entry;
  double median;
};
// The entries of one kind (rk4: the parallel steps; barrier: the bare
// episodes) that count, in the book's order.
std::vector<measured_entry> measured_of(const run_book& book, entry_kind kind);

struct ranked_group {
  unsigned threads = 0;
  kernels::model_choice model;
  platform::placement pin = platform::placement::compact;
  std::vector<measured_entry> entries;  // fastest first
};
std::vector<ranked_group> rank_groups(const run_book& book, entry_kind kind);

// The entries that collapsed (book.collapsed), in numeric thread order, then by name.
std::vector<const captured_entry*> collapsed_entries(const run_book& book);

}  // namespace lockstep::bench
