#pragma once
// The result JSON's "context": what a comparison across machines needs
// (DESIGN.md, Measurements; brief, Agreed formats). Every value is a string,
// as Google Benchmark's custom context requires.
//
// Two parts:
//  * static keys, known before the first entry runs (the build, the machine,
//    the libraries): machine_context() collects them, add_to_benchmark_context()
//    hands them to benchmark::AddCustomContext so that Google Benchmark writes
//    them itself;
//  * in-run keys (c2c_one_way_ns, serial_step_ns, what was not applicable or
//    stalled): known only when the entries that measure them have run, after
//    Google Benchmark wrote its context; `lockstep run` adds them to the file's
//    context before the file is renamed into place.
#include <nlohmann/json_fwd.hpp>

#include <map>
#include <string>

#include "platform/topology.hpp"

namespace lockstep::bench {

using context_map = std::map<std::string, std::string>;

// lockstep_version, lockstep_schema, git_revision, compiler, cxx_flags,
// build_type, sanitizer, cpu_model, hypervisor, kernel, topology,
// topology_packages, topology_l3, topology_cores, topology_pus, hwloc_version,
// benchmark_version, boost_version, clocksource, migrations (available or why
// not). Values the machine cannot give are "unavailable".
context_map machine_context(const platform::topology& machine);

// benchmark::AddCustomContext for every key.
void add_to_benchmark_context(const context_map& context);

// Sets (or replaces) these keys in a Google Benchmark JSON document's context.
void merge_into_result(nlohmann::json& result, const context_map& keys);

// "AMD EPYC" (from /proc/cpuinfo's model name), or "unavailable".
std::string cpu_model();
// The hypervisor's vendor from CPUID leaf 0x40000000 ("KVMKVMKVM" -> "kvm"),
// "none" when the CPU reports no hypervisor, with the container kind appended
// when one is detectable ("kvm (container: docker)").
std::string hypervisor();
// "6.1.0-13-amd64 #1 SMP PREEMPT_DYNAMIC Debian ..." (uname release + version).
std::string kernel();

}  // namespace lockstep::bench
