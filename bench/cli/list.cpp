// lockstep list: every synchronisation primitive, layout and placement (and
// the MPI exchanges, when built with MPI), one line each, from the registries the benchmark matrix iterates (so the list
// cannot drift from what `lockstep run` accepts).
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <memory>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "layouts/registry.hpp"
#include "platform/placement.hpp"
#include "sync/registry.hpp"
#if LOCKSTEP_HAVE_MPI
#include "distributed/registry.hpp"
#endif

namespace lockstep::cli {

namespace {

std::string primitive_tags(const sync::primitive_info& info) {
  std::string tags = info.kind == sync::primitive_kind::barrier ? "barrier" : "dataflow";
  if (info.pure_spin) tags += ", pure-spin";
  if (info.may_lose_wakeups) tags += ", loses wake-ups";
  if (!info.counts_futex_waits) tags += ", futex waits unavailable";
  return tags;
}

// Which primitives' futex_waits_per_step the result JSON carries, and which
// hide their futex calls inside a library (the counter is omitted for those).
std::string futex_waits_note() {
  std::string counted;
  std::string hidden;
  for (const auto& info : sync::all_primitive_info) {
    std::string& list = info.counts_futex_waits ? counted : hidden;
    list += (list.empty() ? "" : ", ") + std::string(info.name);
  }
  return fmt::format(
      "  futex waits (futex_waits_per_step) counted, or 0 because it never sleeps: {}\n"
      "  futex waits unavailable (inside the library; the counter is omitted): {}\n",
      counted.empty() ? "none" : counted, hidden.empty() ? "none" : hidden);
}

// The groups `lockstep list WHAT` shows one of.
const std::vector<std::string> kGroups{"sync", "layout", "placement", "exchange"};

void print_list(const std::string& what) {
  if (what.empty() || what == "sync") {
    fmt::print("Synchronisation primitives (--sync):\n");
    for (const auto& info : sync::all_primitive_info)
      fmt::print("  {:<20} [{}] {}\n", info.name, primitive_tags(info), info.description);
    fmt::print("{}", futex_waits_note());
  }
  if (what.empty() || what == "layout") {
    if (what.empty()) fmt::print("\n");
    fmt::print("Layouts (--layout):\n");
    for (const auto& info : layouts::all_layout_info) fmt::print("  {:<20} {}\n", info.name, info.description);
  }
  if (what.empty() || what == "placement") {
    if (what.empty()) fmt::print("\n");
    fmt::print("Placements (--pin):\n");
    for (const auto& placement : platform::placements())
      fmt::print("  {:<20} {}\n", placement.name, placement.description);
  }
  if (what.empty() || what == "exchange") {
    if (what.empty()) fmt::print("\n");
    fmt::print("MPI exchanges (lockstep mpi --exchange, --sync for shm_window):\n");
#if LOCKSTEP_HAVE_MPI
    for (const auto& entry : distributed::exchanges())
      fmt::print("  {:<22} {}\n", entry.label, entry.description);
#else
    fmt::print("  (this lockstep was built without MPI)\n");
#endif
  }
}

}  // namespace

void add_list(CLI::App& app, int& result) {
  auto what = std::make_shared<std::string>();
  CLI::App* list = app.add_subcommand("list", "List every synchronisation primitive, layout, placement and MPI exchange");
  list->add_option("what", *what, "Only one group: " + joined(kGroups));
  list->callback([what, &result] {
    if (!what->empty()) check_name(*what, kGroups, "unknown list");
    print_list(*what);
    result = kExitOk;
  });
}

}  // namespace lockstep::cli
