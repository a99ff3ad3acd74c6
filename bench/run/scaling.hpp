#pragma once
// The scaling curve of `lockstep run --scaling`: sync time per stage against
// threads, per primitive on its best layout at each thread count (the layout
// with the lowest median there), on one placement. The summary prints it and
// names the primitive that scales best; the JSON carries it as
// "lockstep_scaling" for the report's log-log figure.
//
// "Scales best": of the primitives measured at every thread count of the
// sweep, the one with the lowest sync time per stage at the largest count.
// A chain's consumer waits for its two neighbours while a barrier waits for
// all T, so this is where a dataflow primitive's advantage shows, or not.
#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

#include "bench/run/run_book.hpp"

namespace lockstep::bench {

struct scaling_point {
  std::string sync;
  unsigned threads = 0;
  std::string layout;  // the best at this count
  std::string model;   // "" the paper's two masses, else "chain8"
  double sync_ns_per_stage = 0.0;
  double ns_per_step = 0.0;
  // min and max over the repetitions of the curve's counter: two primitives
  // whose ranges overlap are not separated by the run.
  double lowest = 0.0;
  double highest = 0.0;
  bool oversubscribed = false;
};

struct scaling_curve {
  std::string pin;                    // the placement the sweep held
  std::string counter;                // "sync_ns_per_stage" (or "ns_per_step" with accounting off)
  std::vector<unsigned> threads;      // ascending
  std::vector<scaling_point> points;  // by sync, then threads
  std::optional<std::string> best;    // the primitive that scales best
};

scaling_curve scaling_of(const run_book& book);
// The summary's section ("" when the run measured no curve).
std::string render_scaling(const scaling_curve& curve);
nlohmann::json scaling_json(const scaling_curve& curve, std::optional<double> c2c_one_way_ns);

}  // namespace lockstep::bench
