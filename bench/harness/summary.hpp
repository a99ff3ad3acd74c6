#pragma once
// The summary `lockstep run` prints on stdout when the run is over: every
// number in it comes from the run book (medians over repetitions, spread as
// min..max), never from another run.
#include <string>

#include "bench/harness/run_book.hpp"

namespace lockstep::bench {

// The whole summary as text. `result_path` is where the JSON went.
std::string render_summary(const run_book& book, const std::string& result_path);

// One line saying which entries ran oversubscribed ("threads:4 ran
// oversubscribed on 2 CPUs: 60 entries"), or "none": the context's
// oversubscribed_note.
std::string oversubscribed_note(const run_book& book, unsigned cpus);

}  // namespace lockstep::bench
