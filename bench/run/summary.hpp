#pragma once
// The summary `lockstep run` prints on stdout when the run is over: every
// number in it comes from the run book (medians over repetitions, spread as
// min..max), never from another run.
#include <string>

#include "bench/run/run_book.hpp"
#include "bench/run/run_result.hpp"

namespace lockstep::bench {

// The summary as text, ending with the answer (result.answer). By default
// short: the calibrations, the fastest few combinations of each thread count
// and placement, and the answer; `verbose`: every table (the ranking, the
// bare primitives, every paired ratio, the harness overhead, the entries
// measured in more than one pace mode, what was left out and why).
// `result_path` is where the JSON went.
std::string render_summary(const run_result& result, const std::string& result_path, bool verbose = false);

// One line saying which entries ran oversubscribed ("threads:4 ran
// oversubscribed on 2 CPUs: 60 entries"), or "none": the context's
// oversubscribed_note.
std::string oversubscribed_note(const run_book& book, unsigned cpus);

}  // namespace lockstep::bench
