#pragma once
// What `lockstep run` has when it is over (matrix_run.hpp: run_matrix returns
// it, summary.hpp renders it): the run book (the entries and the pairs), the
// pace modes of the run, --crossover's sweep, and the answer, made once from
// them (answer.hpp).
#include <optional>

#include "bench/run/answer.hpp"
#include "bench/run/crossover.hpp"
#include "bench/run/pace.hpp"
#include "bench/run/run_book.hpp"

namespace lockstep::bench {

struct run_result {
  run_book book;
  // The pace modes the run's trace showed (pace.hpp); empty when no trace was analysed.
  std::optional<pace_modes> pace;
  std::optional<crossover_sweep> crossover;  // --crossover
  run_answer answer;
};

}  // namespace lockstep::bench
