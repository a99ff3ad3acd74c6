#pragma once
// Whether a rank's MPI library gives up the CPU while a wait finds nothing to
// do, and a way to make it: the remedy when two busy-polling ranks must share
// a CPU (rank_placement.hpp). A rank that polls keeps the CPU until the
// scheduler's tick takes it away, so the rank it waits for, on the same CPU,
// runs only once a tick: every hop of a ping-pong costs a tick or two (4 ms
// at HZ=250) instead of microseconds. A rank that yields (sched_yield when
// its progress engine found no event) hands the CPU over at once.
//
// Open MPI: the flag of its progress engine, which MPI_Init sets from the MCA
// parameter mpi_yield_when_idle (and sets by itself when mpirun says the node
// is oversubscribed). The MPI standard has no call for it and the parameter
// is read-only once MPI_Init has read it, so both functions reach the flag
// through Open MPI's own exported symbols (libopen-pal: the variable
// opal_progress_yield_when_idle, the function
// opal_progress_set_yield_when_idle, the one MPI_Init calls), looked up at
// run time: with another MPI library they are absent and the functions say so.
#include <optional>

namespace lockstep::distributed {

// Whether this process's MPI library yields when idle now; nothing when the
// library does not say (not Open MPI). Call after MPI_Init.
[[nodiscard]] std::optional<bool> yields_when_idle() noexcept;

// Makes this process's MPI library yield when idle, as mpi_yield_when_idle=1
// at MPI_Init would have; true when it now does, false when the library
// offers no way (not Open MPI). Call after MPI_Init, from the rank's thread.
bool make_yield_when_idle() noexcept;

}  // namespace lockstep::distributed
