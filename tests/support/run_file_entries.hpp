#pragma once
// A run file's entries read back as typed specs, for the tests that rebuild
// a run book from a file (tests/run/run_fixture_test.cpp) or make one by
// hand. `lockstep run` itself never reads a name back: it writes each row's
// spec as "lockstep_entry" (bench/results/entry_spec.hpp). Files written
// before that key (tests/fixtures/run/quick-pairs.json among them, kept as
// written) have only the name, so spec_from_old_name reads the name the way
// entry_spec::name makes it; it is the fallback for such files, and nothing
// else in C++ parses a name.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <map>
#include <stdexcept>
#include <string>

#include "bench/results/entry_spec.hpp"
#include "kernels/model_choice.hpp"
#include "platform/placement.hpp"

namespace lockstep::testing {

// The spec of a name written before "lockstep_entry" (docs/names-and-counters.md):
// the kind, then key:value segments and, for rk4/serial, the bare word "serial".
inline bench::entry_spec spec_from_old_name(const std::string& name) {
  std::map<std::string, std::string> fields;
  std::string kind;
  std::size_t start = 0;
  while (start <= name.size()) {
    std::size_t end = name.find('/', start);
    if (end == std::string::npos) end = name.size();
    const std::string segment = name.substr(start, end - start);
    const std::size_t colon = segment.find(':');
    if (kind.empty()) kind = segment;
    else if (colon == std::string::npos) fields["variant"] = segment;
    else fields[segment.substr(0, colon)] = segment.substr(colon + 1);
    start = end + 1;
  }
  const auto field = [&](const char* key) {
    const auto found = fields.find(key);
    return found == fields.end() ? std::string() : found->second;
  };
  kernels::model_choice model;
  if (const std::string chain = field("model"); !chain.empty()) model.masses = std::stoul(chain.substr(5));  // "chainS"
  const platform::placement pin = platform::parse_placement(field("pin").empty() ? "none" : field("pin"));
  const unsigned threads = field("threads").empty() ? 1u : static_cast<unsigned>(std::stoul(field("threads")));
  if (kind == "c2c") return bench::entry_spec::c2c_calibration();
  if (kind == "rk4" && field("variant") == "serial") return bench::entry_spec::serial_step(model);
  if (kind == "barrier") return bench::entry_spec::barrier_episode(field("sync"), pin, threads);
  if (kind == "rk4") return bench::entry_spec::parallel_step(field("sync"), field("layout"), pin, threads, model);
  if (kind == "overhead")
    return bench::entry_spec::overhead_side(field("accounting") == "on", field("sync"), field("layout"), pin, threads,
                                            model);
  throw std::invalid_argument("not a lockstep run entry: " + name);
}

// A row's spec: its "lockstep_entry" where the file has one, else its name's.
inline bench::entry_spec spec_of_row(const nlohmann::json& row) {
  const auto written = row.find("lockstep_entry");
  if (written == row.end()) return spec_from_old_name(row.at("run_name").get<std::string>());
  const auto text = [&](const char* key) {
    const auto& value = written->at(key);
    return value.is_null() ? std::string() : value.get<std::string>();
  };
  const std::string kind = text("kind");
  const kernels::model_choice model{written->at("masses").get<std::size_t>()};
  const platform::placement pin = platform::parse_placement(kind == "serial" ? "none" : text("pin"));
  const unsigned threads = written->at("threads").get<unsigned>();
  if (kind == "c2c") return bench::entry_spec::c2c_calibration();
  if (kind == "serial") return bench::entry_spec::serial_step(model);
  if (kind == "barrier") return bench::entry_spec::barrier_episode(text("sync"), pin, threads);
  if (kind == "rk4") return bench::entry_spec::parallel_step(text("sync"), text("layout"), pin, threads, model);
  return bench::entry_spec::overhead_side(written->at("accounting").get<bool>(), text("sync"), text("layout"), pin,
                                          threads, model);
}

}  // namespace lockstep::testing
