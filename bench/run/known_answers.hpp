#pragma once
// The known answers a run sets its step's ratios beside (answer.hpp:
// known_answers), each a short run of a probe lockstep also has as a command.
#include "bench/run/answer.hpp"
#include "platform/topology.hpp"

namespace lockstep::bench {

// Measures them on the first two CPUs of the compact plan; a probe that
// cannot run leaves its figure absent with the reason why.
known_answers measure_known_answers(const platform::topology& machine, bool quick);

}  // namespace lockstep::bench
