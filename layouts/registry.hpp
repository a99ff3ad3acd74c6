#pragma once
// Every layout of lockstep, as one compile-time list, so that `lockstep list`,
// the rk4 matrix, `delay` and the bitwise oracle iterate the same list: a new
// layout joins everything by joining all_layouts (layouts.hpp).
#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <tuple>

#include "layouts/layouts.hpp"

namespace lockstep::layouts {

struct layout_info {
  std::string_view name;
  std::string_view description;
};

// Calls visit.template operator()<Layout>() for every layout, in order.
template <class Visitor>
constexpr void for_each_layout(Visitor&& visit) {
  [&]<class... Layouts>(std::tuple<Layouts...>*) {
    (visit.template operator()<Layouts>(), ...);
  }(static_cast<all_layouts*>(nullptr));
}

inline constexpr auto all_layout_info = []<class... Layouts>(std::tuple<Layouts...>*) {
  return std::array<layout_info, sizeof...(Layouts)>{layout_info{Layouts::kName, Layouts::kDescription}...};
}(static_cast<all_layouts*>(nullptr));

// nullptr when no layout has that name.
constexpr const layout_info* find_layout(std::string_view name) noexcept {
  for (const auto& info : all_layout_info)
    if (info.name == name) return &info;
  return nullptr;
}

// "packed, padded64, ...": for messages that list the valid names.
inline std::string layout_names() {
  std::string names;
  for (const auto& info : all_layout_info) names += (names.empty() ? "" : ", ") + std::string(info.name);
  return names;
}

}  // namespace lockstep::layouts
