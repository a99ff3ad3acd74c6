// The result JSON's context (machine_context.hpp).
#include "bench/results/machine_context.hpp"

#include <sys/utsname.h>
#include <unistd.h>

#if defined(__x86_64__) || defined(__i386__)
#include <cpuid.h>
#endif

#include <boost/version.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cstring>
#include <fstream>

#include "bench/results/build_info.hpp"
#include "bench/results/machine_state_context.hpp"
#include "platform/cache_line.hpp"
#include "platform/clock.hpp"
#include "platform/cpu_identity.hpp"
#include "platform/thread_accounting.hpp"
#include "platform/wait_calibration.hpp"

#ifndef LOCKSTEP_BENCHMARK_VERSION
#define LOCKSTEP_BENCHMARK_VERSION "unavailable"
#endif

namespace lockstep::bench {

std::string cpu_model() { return platform::cpu_model(); }

namespace {

std::string container_kind() {
  if (::access("/.dockerenv", F_OK) == 0) return "docker";
  if (::access("/run/.containerenv", F_OK) == 0) return "podman";
  std::ifstream environ_of_init("/proc/1/environ");
  std::string entry;
  while (std::getline(environ_of_init, entry, '\0'))
    if (entry.rfind("container=", 0) == 0) return entry.substr(10);
  return {};
}

}  // namespace

std::string hypervisor() {
  std::string vendor = "none";
#if defined(__x86_64__) || defined(__i386__)
  unsigned eax = 0;
  unsigned ebx = 0;
  unsigned ecx = 0;
  unsigned edx = 0;
  // CPUID.1:ECX bit 31 is the "running under a hypervisor" bit.
  if (__get_cpuid(1, &eax, &ebx, &ecx, &edx) != 0 && (ecx & (1u << 31)) != 0) {
    __cpuid(0x40000000, eax, ebx, ecx, edx);
    std::array<char, 13> signature{};
    std::memcpy(signature.data() + 0, &ebx, 4);
    std::memcpy(signature.data() + 4, &ecx, 4);
    std::memcpy(signature.data() + 8, &edx, 4);
    const std::string raw(signature.data());
    if (raw.rfind("KVMKVMKVM", 0) == 0) vendor = "kvm";
    else if (raw == "Microsoft Hv") vendor = "hyper-v";
    else if (raw == "VMwareVMware") vendor = "vmware";
    else if (raw == "XenVMMXenVMM") vendor = "xen";
    else if (raw.rfind("TCGTCGTCG", 0) == 0) vendor = "qemu-tcg";
    else if (raw == "ACRNACRNACRN") vendor = "acrn";
    else if (raw.empty()) vendor = "unknown hypervisor";
    else vendor = raw;
  }
#else
  vendor = "unavailable";
#endif
  const std::string container = container_kind();
  if (!container.empty()) vendor += " (container: " + container + ")";
  return vendor;
}

std::string kernel() {
  utsname name{};
  if (::uname(&name) != 0) return "unavailable";
  return std::string(name.release) + " " + name.version;
}

nlohmann::json machine_context(const platform::topology& machine) {
  nlohmann::json context = nlohmann::json::object();
  context["lockstep_version"] = build_info::kVersion;
  context["lockstep_schema"] = std::to_string(build_info::kResultSchema);
  context["git_revision"] = build_info::git_revision();
  context["compiler"] = build_info::kCompiler;
  context["cxx_flags"] = build_info::kCxxFlags;
  context["build_type"] = build_info::kBuildType;
  context["sanitizer"] = *build_info::kSanitizer == '\0' ? "none" : build_info::kSanitizer;
  context["cpu_model"] = cpu_model();
  context["hypervisor"] = hypervisor();
  context["kernel"] = kernel();
  std::array<char, 256> host{};
  context["host_name"] = ::gethostname(host.data(), host.size() - 1) == 0 ? host.data() : "unavailable";
  context["num_cpus"] = ::sysconf(_SC_NPROCESSORS_ONLN);
  context["topology"] = machine.summary();
  context["topology_packages"] = std::to_string(machine.packages());
  context["topology_l3"] = std::to_string(machine.l3_domains());
  context["topology_cores"] = std::to_string(machine.core_count());
  context["topology_pus"] = std::to_string(machine.pu_count());
  // Each CPU's place, position = the CPU's number (platform/topology.hpp, cpu_table).
  const platform::topology::per_cpu_table cpus = machine.cpu_table();
  context["topology_numa_nodes"] = std::to_string(machine.numa_nodes());
  context["topology_kinds"] = cpus.kinds.empty() ? "none" : cpus.kinds;
  context["topology_cpu_package"] = cpus.package;
  context["topology_cpu_l3"] = cpus.l3;
  context["topology_cpu_numa_node"] = cpus.numa_node;
  context["topology_cpu_core"] = cpus.core;
  context["topology_cpu_kind"] = cpus.kind;
  context["affinity_cpus"] = std::to_string(machine.affinity().size());
  context["hwloc_version"] = machine.hwloc_version();
  context["benchmark_version"] = LOCKSTEP_BENCHMARK_VERSION;
  context["boost_version"] = fmt::format("{}.{}.{}", BOOST_VERSION / 100000, BOOST_VERSION / 100 % 1000,
                                         BOOST_VERSION % 100);
  context["clocksource"] = platform::clocksource();
  context["migrations"] = platform::migrations_available()
                              ? "available (se.nr_migrations in /proc/self/task/TID/sched)"
                              : "unavailable (no se.nr_migrations in /proc/self/task/TID/sched): "
                                "migrations_per_kstep and cross_core_csw_pct are omitted";
  add_machine_state(context, machine.affinity());
  const nlohmann::json constants = machine_constants();
  for (const auto& [key, value] : constants.items()) context[key] = value;
  return context;
}

nlohmann::json machine_constants() {
  nlohmann::json constants = nlohmann::json::object();
  const platform::cache_line_reading line = platform::machine_cache_line();
  constants["cache_line_bytes"] = std::to_string(line.bytes);
  constants["cache_line_source"] = line.source;
  const platform::wait_calibration& waits = platform::machine_wait_calibration();
  constants["spin_hint"] = std::string(waits.hint);
  constants["spin_poll_ns"] = fmt::format("{:.2f}", waits.poll_ns);
  constants["futex_round_trip_ns"] = fmt::format("{:.0f}", waits.futex.ns);
  constants["futex_round_trip_p90_ns"] = fmt::format("{:.0f}", waits.futex.p90_ns);
  constants["futex_round_trip_source"] = waits.futex.how;
  constants["spin_budget_polls"] = std::to_string(waits.round_trip_spin_polls());
  return constants;
}


void merge_into_result(nlohmann::json& result, const context_map& keys) {
  nlohmann::json& context = result["context"];
  for (const auto& [key, value] : keys) context[key] = value;
}

void merge_into_result(nlohmann::json& result, const nlohmann::json& keys) {
  nlohmann::json& context = result["context"];
  for (const auto& [key, value] : keys.items()) context[key] = value;
}

nlohmann::json result_document(const std::string& kind, const platform::topology& machine) {
  nlohmann::json document = {{"kind", kind}, {"lockstep_schema", build_info::kResultSchema}};
  merge_into_result(document, machine_context(machine));
  return document;
}


}  // namespace lockstep::bench
