// The one ranking of a run's entries (ranking.hpp).
#include "bench/run/ranking.hpp"

#include <algorithm>
#include <string_view>
#include <tuple>

namespace lockstep::bench {

std::vector<measured_entry> measured_of(const run_book& book, entry_kind kind) {
  std::vector<measured_entry> found;
  for (const auto& entry : book.entries()) {
    if (entry.spec.kind != kind || !entry.error.empty() || book.collapsed.count(entry.name) > 0) continue;
    if (const auto median = entry.median_time()) found.push_back({&entry, *median});
  }
  return found;
}

std::vector<ranked_group> rank_groups(const run_book& book, entry_kind kind) {
  const auto key = [](const entry_spec& spec) {
    return std::tuple(spec.threads, spec.model.masses, platform::to_string(spec.pin));
  };
  std::vector<measured_entry> measured = measured_of(book, kind);
  std::stable_sort(measured.begin(), measured.end(), [&](const measured_entry& a, const measured_entry& b) {
    return std::tuple_cat(key(a.entry->spec), std::tuple(a.median)) <
           std::tuple_cat(key(b.entry->spec), std::tuple(b.median));
  });
  std::vector<ranked_group> groups;
  for (const measured_entry& item : measured) {
    const entry_spec& spec = item.entry->spec;
    if (groups.empty() || key(groups.back().entries.front().entry->spec) != key(spec))
      groups.push_back({spec.threads, spec.model, spec.pin, {}});
    groups.back().entries.push_back(item);
  }
  return groups;
}

std::vector<const captured_entry*> collapsed_entries(const run_book& book) {
  std::vector<const captured_entry*> collapsed;
  for (const auto& entry : book.entries())
    if (book.collapsed.count(entry.name) > 0) collapsed.push_back(&entry);
  std::sort(collapsed.begin(), collapsed.end(), [](const captured_entry* a, const captured_entry* b) {
    return std::tie(a->spec.threads, a->name) < std::tie(b->spec.threads, b->name);
  });
  return collapsed;
}

}  // namespace lockstep::bench
