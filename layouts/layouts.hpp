#pragma once
// Every layout, in the order `lockstep list` and the benchmark matrix show them.
#include <tuple>

#include "layouts/packed.hpp"
#include "layouts/padded.hpp"
#include "layouts/per_thread.hpp"

namespace lockstep::layouts {

using all_layouts = std::tuple<packed, padded64, padded128, per_thread>;

}  // namespace lockstep::layouts
