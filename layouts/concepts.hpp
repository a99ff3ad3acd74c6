#pragma once
// The contract every layout listed in layouts/registry.hpp satisfies, as the
// primitives' is in sync/concepts.hpp: the facts the harness and the tests
// act on are traits the layout declares (never recovered from its name), and
// the members the composed step (kernels/parallel_exchange.hpp) calls exist
// for the layout's kind. One concept per trait, each named after it, so that
// a layout lacking one fails with "required for the satisfaction of
// 'layout_declares_writer_isolation<L>' ... the required expression
// 'L::kWriterIsolation' is invalid".
#include <concepts>
#include <cstddef>
#include <string_view>

#include "layouts/partition.hpp"
#include "layouts/shared_slots.hpp"

namespace lockstep::layouts {

// kName: the name docs/design.md lists, unique in the registry; benchmark names carry it.
template <class L>
concept layout_declares_name = requires {
  { L::kName } -> std::convertible_to<std::string_view>;
};
// kDescription: one line for `lockstep list`.
template <class L>
concept layout_declares_description = requires {
  { L::kDescription } -> std::convertible_to<std::string_view>;
};
// kKind: shared (the slots are the state, read and written in place) or
// private_copy (each participant computes from a copy of its own and copies
// in what others published). shared_slots.hpp says what each holds.
template <class L>
concept layout_declares_kind = requires {
  { L::kKind } -> std::same_as<const layout_kind&>;
};
// kWriterIsolation: the size in bytes of the aligned blocks in which every
// value has one writer (no two participants write into one such block), or
// 0 when the layout puts different writers' values side by side on purpose
// (packed: the false-sharing case). The layout's static_asserts prove it for
// the paper's case; tests/matrix/layouts_test.cpp checks it at run time for
// the shapes the matrix runs.
template <class L>
concept layout_declares_writer_isolation = requires {
  { L::kWriterIsolation } -> std::same_as<const std::size_t&>;
};

// What the composed step calls on a shared layout: x_n by step parity and
// k_0..k_2, in place, for any equation.
template <class L>
concept shared_slots_layout = std::constructible_from<L, const partition&> &&
                              requires(L& layout, unsigned parity, unsigned stage, std::size_t equation) {
                                { layout.state(parity, equation) } -> std::same_as<double&>;
                                { layout.stage(stage, equation) } -> std::same_as<double&>;
                              };
// What it calls on a private_copy layout: each participant's copy of x and
// k_0..k_3, and the publication board (k_0..k_2 and x_next per equation).
template <class L>
concept private_copy_layout =
    std::constructible_from<L, const partition&> &&
    requires(L& layout, unsigned participant, unsigned stage, std::size_t slot, std::size_t equation) {
      { layout.private_state(participant) } -> std::same_as<double*>;
      { layout.private_stage(participant, stage) } -> std::same_as<double*>;
      { layout.board(slot, equation) } -> std::same_as<double&>;
    };

// What kKind says is what the type offers.
template <class L>
concept layout_shape_matches_kind = (L::kKind == layout_kind::shared && shared_slots_layout<L>) ||
                                    (L::kKind == layout_kind::private_copy && private_copy_layout<L>);

// What layouts/registry.hpp requires of every layout it lists.
template <class L>
concept registered_layout = layout_declares_name<L> && layout_declares_description<L> && layout_declares_kind<L> &&
                            layout_declares_writer_isolation<L> && layout_shape_matches_kind<L>;

}  // namespace lockstep::layouts
