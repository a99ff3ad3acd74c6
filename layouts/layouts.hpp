#pragma once
// Every layout, in the order `lockstep list` and the benchmark matrix show
// them: layouts::all_layouts, kept here for the includes that know this
// header. The list and what it offers live in layouts/registry.hpp.
#include "layouts/registry.hpp"
