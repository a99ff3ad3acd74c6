#pragma once
// The pace trace: how fast the machine was, moment by moment, during a run.
//
// Why: a VM (and a shared server) changes pace for seconds to tens of seconds
// at a time, by where the host places its vCPUs. On the development VM the
// one-way core-to-core latency reads about 25 ns, 55 ns or 120-270 ns by
// stretches, and every primitive's cost moves with it, so an entry measured in
// one stretch and its rival in another differ for no reason of their own.
//
// What: between blocks of measurement the harness takes a *reading*: the
// one-way core-to-core latency between the two CPUs the compact plan puts its
// first two participants on (CAS ping-pong, core_to_core.hpp, a few thousand
// round trips: about 0.1-0.4 ms with the thread start-up), and the serial RK4
// step (a few hundred steps: tens of microseconds). The readings, in time
// order, are the trace. A *mode* is a pace the machine keeps for a while:
// readings whose c2c latency (the serial step on a machine with one CPU)
// clusters apart from the others by more than kModeGap.
//
// Who reads it: every repetition of an entry carries the readings taken just
// before and just after it (its pace, and its mode when both agree); every
// pair of blocks of a paired comparison (paired_blocks.hpp) the readings just
// before and after it. The
// summary says what the modes were and how often the machine changed between
// them; compare and the report read the same trace from the JSON.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "platform/topology.hpp"

namespace lockstep::bench {

struct pace_reading {
  double t_s = 0.0;               // seconds since the trace started
  std::optional<double> c2c_ns;   // one-way latency; empty with one CPU
  double serial_ns = 0.0;         // one serial RK4 step
  // The figure that modes are found on: c2c when there is one.
  double key() const noexcept { return c2c_ns.value_or(serial_ns); }
};

struct pace_mode {
  double c2c_ns = 0.0;     // median of the mode's readings (0 when unavailable)
  double serial_ns = 0.0;  // median of the mode's readings
  double share = 0.0;      // fraction of the trace's time spent in it (0..1)
  std::size_t readings = 0;
};

struct pace_modes {
  std::vector<pace_mode> modes;        // fastest first
  std::vector<int> mode_of;            // per reading: index into modes, or -1 (an outlier)
  unsigned changes = 0;                // switches between consecutive readings' modes, outliers skipped
  bool has_c2c = false;
  // "c2c 25 ns for 61 % of the run, 118 ns for 39 %; 3 changes"
  std::string summary() const;
};

// Two sorted neighbours whose key differs by more than this factor belong to
// different modes. The development VM's modes sit about 2x apart (25, 55,
// 120-270 ns); within a mode, readings of a few thousand round trips agree to
// within about 20 % (a preempted reading lands alone, as an outlier).
inline constexpr double kModeGap = 1.5;
// A cluster of fewer readings than this is not a mode: its readings are
// outliers (a preemption during the reading, a page fault).
inline constexpr std::size_t kMinModeReadings = 3;

// The modes of a trace (pure: unit-tested on synthetic traces).
pace_modes find_modes(const std::vector<pace_reading>& trace);

// The mode two readings agree on (a repetition's before and after), or -1.
int agreed_mode(const pace_modes& modes, std::size_t before, std::size_t after);

// Takes readings and keeps the trace. Not thread-safe: the benchmark thread
// alone calls it, between calls of entries (no team is running).
class pace_probe {
 public:
  // Reads on the first two PUs of the compact plan; one CPU: serial only.
  explicit pace_probe(const platform::topology& machine);

  // Takes a reading now and returns its index in the trace.
  std::size_t take();
  // The index of the last reading if it is at most `fresh_ns` old, else a new one.
  std::size_t latest_or_take(std::int64_t fresh_ns);

  const std::vector<pace_reading>& trace() const noexcept { return trace_; }
  const std::vector<unsigned>& cpus() const noexcept { return cpus_; }
  // What a reading is, for people (the JSON's "reference").
  std::string reference() const;

 private:
  std::vector<unsigned> cpus_;
  std::int64_t start_ns_;
  std::int64_t last_ns_ = 0;
  std::vector<pace_reading> trace_;
};

// The JSON's "lockstep_pace" (bench/run: the contract with reports/).
nlohmann::json pace_json(const pace_probe& probe, const pace_modes& modes);

}  // namespace lockstep::bench
