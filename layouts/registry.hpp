#pragma once
// Every data layout of lockstep, as one compile-time list, so that `lockstep
// list`, the `rk4/...` matrix, `delay`, the bitwise oracle and the layout
// tests all iterate the same list: a new layout joins everything by joining
// all_layouts (its header plus one line here).
//
// Every listed layout satisfies registered_layout (layouts/concepts.hpp): it
// declares each trait below as a static constexpr member, and a layout that
// lacks one fails to compile here with the trait's name.
//
// For each layout L:
//   info_of<L>()   name (docs/design.md's), one-line description, kind (shared or
//                  private_copy), writer_isolation (bytes of the blocks in
//                  which every value has one writer; 0 = writers share lines
//                  on purpose).
//
// Usage:
//   for_each_layout([]<class L>() { ... info_of<L>() ... });
//   for (const layout_info& info : all_layout_info) ...
//   find_layout("padded64")  (nullptr when no layout has that name)
//   writer_isolation_note(platform::machine_cache_line().bytes)
//                            whether each layout's writer isolation holds on
//                            the machine's line, as one line for a run
#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <tuple>

#include <fmt/core.h>

#include "layouts/concepts.hpp"
#include "layouts/packed.hpp"
#include "layouts/padded.hpp"
#include "layouts/per_thread.hpp"
#include "platform/cache_line.hpp"

namespace lockstep::layouts {

// docs/design.md's table order. A std::tuple of the layout types (never
// instantiated: only its element types are used).
using all_layouts = std::tuple<packed, padded64, padded128, per_thread>;

struct layout_info {
  std::string_view name;
  std::string_view description;
  layout_kind kind;
  std::size_t writer_isolation;  // bytes; 0 = different writers' values share lines on purpose
};

template <registered_layout Layout>
constexpr layout_info info_of() noexcept {
  return {Layout::kName, Layout::kDescription, Layout::kKind, Layout::kWriterIsolation};
}

// Calls visit.template operator()<L>() for every L in the list, in order.
template <class List>
struct for_each_layout_in;
template <class... Layouts>
struct for_each_layout_in<std::tuple<Layouts...>> {
  template <class Visitor>
  static constexpr void apply(Visitor&& visit) {
    (visit.template operator()<Layouts>(), ...);
  }
};
template <class List = all_layouts, class Visitor>
constexpr void for_each_layout(Visitor&& visit) {
  for_each_layout_in<List>::apply(visit);
}

template <class List>
struct layout_info_table;
template <class... Layouts>
struct layout_info_table<std::tuple<Layouts...>> {
  static constexpr std::array<layout_info, sizeof...(Layouts)> value{info_of<Layouts>()...};
};
inline constexpr auto all_layout_info = layout_info_table<all_layouts>::value;

// nullptr when no layout has that name (for --layout filters and `list`).
constexpr const layout_info* find_layout(std::string_view name) noexcept {
  for (const auto& info : all_layout_info)
    if (info.name == name) return &info;
  return nullptr;
}

// Whether a layout keeps its writers on separate lines of a machine whose
// cache line is `line_bytes`: it claims isolation (not packed) and its blocks
// are at least a line (every size here is a power of two, so a block is then
// a whole number of lines, aligned to them).
constexpr bool isolates_writers(const layout_info& layout, std::size_t line_bytes) noexcept {
  return layout.writer_isolation != 0 && layout.writer_isolation >= line_bytes;
}

// One line for a run's summary and context: that every layout claiming writer
// isolation has it on this line, or which do not and what that means for
// what they measure (their claim is compile-time; the line is the machine's).
inline std::string writer_isolation_note(std::size_t line_bytes) {
  std::string narrower;
  for (const layout_info& layout : all_layout_info) {
    if (layout.writer_isolation == 0 || isolates_writers(layout, line_bytes)) continue;
    narrower += fmt::format("{}{} ({} bytes)", narrower.empty() ? "" : ", ", layout.name, layout.writer_isolation);
  }
  if (narrower.empty())
    return fmt::format("holds: every layout that keeps writers apart does so on this machine's {}-byte cache line",
                       line_bytes);
  return fmt::format(
      "does not hold for {}: blocks narrower than this machine's {}-byte cache line, so two participants' values "
      "share a line and these layouts measure false sharing like packed, not its absence (the primitives' own "
      "words are {}-byte aligned too)",
      narrower, line_bytes, platform::kCacheLine);
}

namespace detail {
constexpr bool layout_names_unique() {
  for (std::size_t first = 0; first < all_layout_info.size(); ++first)
    for (std::size_t second = first + 1; second < all_layout_info.size(); ++second)
      if (all_layout_info[first].name == all_layout_info[second].name) return false;
  return true;
}
}  // namespace detail
static_assert(detail::layout_names_unique(), "every layout needs its own name (the benchmark names use it)");

}  // namespace lockstep::layouts
