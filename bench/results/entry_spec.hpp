#pragma once
// One benchmark entry of `lockstep run`, typed: what it measures (its kind),
// on which primitive, layout, placement and thread count, which model, and
// what its time counts (a step, an episode or a one-way transfer). It is made
// once, at registration (bench/run/rk4_entries.cpp, barrier_entries.cpp, where
// kernels::model_for picks each entry's model), and travels as it is: the run
// book, the pairs, the summary, the answer, the scaling curve, the derived
// sections and the crossover read its fields, never its name.
//
// The name (docs/names-and-counters.md) is made here and only here, for
// Google Benchmark and the result file's "name"; nothing in C++ parses it
// back. The result file carries the same fields as values, "lockstep_entry"
// on every row of its "benchmarks" (entry_json below;
// docs/schemas/run.schema.json), so that the reports read them instead of
// splitting names.
#include <nlohmann/json.hpp>

#include <string>
#include <string_view>

#include "kernels/model_choice.hpp"
#include "platform/placement.hpp"

namespace lockstep::bench {

// What an entry measures (the name's first segment; a serial step is rk4/serial).
enum class entry_kind { c2c, serial, barrier, rk4, overhead };
// What an entry's time counts: one RK4 step (rk4, serial, overhead), one
// episode of a bare primitive (barrier), one one-way core-to-core transfer (c2c).
enum class entry_unit { step, episode, one_way };

std::string_view to_string(entry_kind kind) noexcept;
std::string_view to_string(entry_unit unit) noexcept;

struct entry_spec {
  entry_kind kind = entry_kind::rk4;
  std::string sync;    // barrier, rk4, overhead
  std::string layout;  // rk4, overhead
  platform::placement pin = platform::placement::compact;  // every kind but serial
  unsigned threads = 1;
  kernels::model_choice model;  // rk4, serial, overhead: the model the step integrates
  bool accounting = true;       // overhead: which side of the pair

  // The entries a run registers, each with what its kind uses.
  static entry_spec c2c_calibration();  // c2c/pin:compact/threads:2, the run's latency calibration
  static entry_spec serial_step(kernels::model_choice model);
  static entry_spec barrier_episode(std::string sync, platform::placement pin, unsigned threads);
  static entry_spec parallel_step(std::string sync, std::string layout, platform::placement pin, unsigned threads,
                                  kernels::model_choice model);
  static entry_spec overhead_side(bool accounting, std::string sync, std::string layout, platform::placement pin,
                                  unsigned threads, kernels::model_choice model);

  // What the entry's time counts (its kind decides: the one place).
  [[nodiscard]] entry_unit unit() const noexcept;
  // The counter that holds its time per unit: ns_per_step, ns_per_episode or one_way_ns.
  [[nodiscard]] std::string_view time_counter() const noexcept;
  // The composed parallel step of a primitive and a layout (rk4 and
  // overhead entries): the entries that carry vs_serial and vs_c2c.
  [[nodiscard]] bool is_parallel_step() const noexcept {
    return kind == entry_kind::rk4 || kind == entry_kind::overhead;
  }

  // rk4/sync:S/layout:L/pin:P/threads:T, rk4/serial, barrier/sync:S/pin:P/threads:T,
  // c2c/pin:compact/threads:2, overhead/accounting:on|off/sync:S/layout:L/pin:P/threads:T;
  // a chain's entries carry its model after the kind: rk4/model:chain8/sync:..., rk4/model:chain8/serial
  [[nodiscard]] std::string name() const;

  friend bool operator==(const entry_spec&, const entry_spec&) = default;
};

// The result file's "lockstep_entry" (docs/schemas/run.schema.json): kind,
// sync, layout, pin (null where the kind has none), threads, model (the
// name's model segment: "" for the paper's two-mass system), masses (0 for
// it), accounting and unit.
nlohmann::json entry_json(const entry_spec& spec);

}  // namespace lockstep::bench
