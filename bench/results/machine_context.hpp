#pragma once
// The result JSON's "context": what a comparison across machines needs
// (docs/result-files.md). Every value is a string (num_cpus excepted, a
// number as Google Benchmark writes it), as Google Benchmark's custom context requires.
//
// One producer for every command that writes a result (run, c2c, delay,
// falseshare, migrate, verify): machine_context() is the machine and build
// fingerprint, the same keys with the same values whichever command asks, so
// that `lockstep compare` can tell "another machine" from "another run".
// Commands add their own keys beside it (lockstep_mode, c2c_one_way_ns, ...),
// never another value for a fingerprint key. The machine state's keys are
// read when the context is made; two of them are the command's own readings
// (kPerCommandStateKeys in bench/results/machine_state_context.hpp). `lockstep run` merges it into
// Google Benchmark's context after the run (replacing Google Benchmark's own
// host_name and num_cpus with the same figures from here).
#include <nlohmann/json.hpp>

#include <array>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "platform/topology.hpp"

namespace lockstep::bench {

using context_map = std::map<std::string, std::string>;

// lockstep_version, lockstep_schema, git_revision, compiler, cxx_flags,
// build_type, sanitizer, cpu_model, hypervisor, kernel, host_name, num_cpus, topology,
// topology_packages, topology_l3, topology_cores, topology_pus, topology_numa_nodes,
// topology_kinds (kind names by index, "none"), the per-CPU table topology_cpu_package,
// topology_cpu_l3, topology_cpu_numa_node, topology_cpu_core, topology_cpu_kind (comma lists,
// position = the CPU's number; platform/topology.hpp, cpu_table), hwloc_version,
// benchmark_version, boost_version, clocksource, migrations (available or why
// not), the machine's state: governor, boost, SMT, isolated CPUs, IRQs,
// huge pages, the frequency during the command (add_machine_state,
// bench/results/machine_state_context.hpp, for the CPUs of the affinity set),
// and machine_constants()'s keys. Values the machine cannot give are
// "unavailable".
// Every value is a string but num_cpus, a whole number as Google Benchmark
// writes it (a reader of either file sees one type).
nlohmann::json machine_context(const platform::topology& machine);

// The constants a result's times depend on that lockstep reads or measures on
// the machine instead of compiling in:
//   cache_line_bytes, cache_line_source   platform::machine_cache_line()
//   spin_hint                             the instruction a spin poll issues (platform/cpu_relax.hpp)
//   spin_poll_ns                          one poll of a spin loop, measured at start-up
//   futex_round_trip_ns, futex_round_trip_p90_ns, futex_round_trip_source
//                                         the futex hand-over's median and 90th percentile,
//                                         measured at start-up (or the assumed figure, and why)
//   spin_budget_polls                     the polls a dedicated wait spins: the 90th percentile
//                                         round trip at spin_poll_ns (sync/wait_policy.hpp)
// from platform::machine_wait_calibration(), measured once per process (its
// first call measures: 1-60 ms).
nlohmann::json machine_constants();
// The keys of machine_constants() that each process measures afresh: two
// runs on one machine write different values (as c2c_one_way_ns), so they are
// not fingerprint keys and the one-machine check skips them.
inline constexpr std::array<std::string_view, 5> kMeasuredContextKeys = {
    "spin_poll_ns", "futex_round_trip_ns", "futex_round_trip_p90_ns", "futex_round_trip_source", "spin_budget_polls"};

// Sets (or replaces) these keys in a result document's context.
void merge_into_result(nlohmann::json& result, const context_map& keys);
void merge_into_result(nlohmann::json& result, const nlohmann::json& keys);

// A new result document of one kind ("c2c", "delay", "falseshare", "migrate",
// "verify"): {"kind", "lockstep_schema", "context": machine_context(machine)}.
nlohmann::json result_document(const std::string& kind, const platform::topology& machine);


// The CPU's name from /proc/cpuinfo (platform/cpu_identity.hpp: x86's model
// name; arm64's MIDR implementer and part, named), or "unavailable".
std::string cpu_model();
// The hypervisor's vendor from CPUID leaf 0x40000000 ("KVMKVMKVM" -> "kvm"),
// "none" when the CPU reports no hypervisor, with the container kind appended
// when one is detectable ("kvm (container: docker)").
std::string hypervisor();
// "6.1.0-13-amd64 #1 SMP PREEMPT_DYNAMIC Debian ..." (uname release + version).
std::string kernel();

}  // namespace lockstep::bench
