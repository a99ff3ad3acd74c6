#pragma once
// Teams: how a primitive's participants get their threads.
//
// A team runs body(id) once for every participant id in [0, participants) and
// returns when every body has returned. Most primitives run on plain threads
// (std_thread_team); OpenMP's barrier only works inside an OpenMP parallel
// region, so omp_barrier runs on omp_team. team_of<S> names the team of a
// primitive S (std_thread_team unless S says otherwise), so that tests and
// benchmarks write one body and never branch on the primitive.
//
// Contract (both teams)
//  * run() may be called many times, never concurrently on one team.
//  * A body must not throw: a participant that left its barrier early would
//    leave the others waiting forever, so an escaping exception terminates.
//  * Affinity: a body may pin its own thread (placement does); std_thread_team
//    threads end with the run, omp_team's thread 0 is the caller (see below).
// Memory ordering: everything before run() happens-before every body, and
// every body happens-before run() returns (thread start and join; the OpenMP
// parallel region's implicit barriers).
#include <cassert>
#include <functional>
#include <string_view>
#include <thread>
#include <vector>

namespace lockstep::sync {

// Every participant on a new std::thread; the calling thread only waits.
// Chosen over "participant 0 runs on the caller" so that every participant
// starts the same way (the paper's native model: the main thread creates the
// workers and joins them), and so that a body that pins its thread never
// changes the caller's affinity (Google Benchmark's thread, a test's main).
class std_thread_team {
 public:
  static constexpr std::string_view kName = "std_thread";

  explicit std_thread_team(unsigned participants) : participants_(participants) { assert(participants >= 1); }

  unsigned participants() const noexcept { return participants_; }

  template <class Body>
  void run(Body&& body) {
    std::vector<std::jthread> threads;
    threads.reserve(participants_);
    for (unsigned id = 0; id < participants_; ++id) threads.emplace_back([&body, id]() noexcept { body(id); });
    // jthread joins on destruction: every body has returned when run() does.
  }

 private:
  unsigned participants_;
};

// An OpenMP parallel region of exactly `participants` threads (libgomp);
// participant id = omp_get_thread_num(). OpenMP makes the calling thread
// thread 0 of the region, so participant 0 runs on the caller (and a body that
// pins participant 0 pins the caller: restore it afterwards if it matters).
// Throws std::runtime_error if the runtime grants fewer threads than asked
// (OMP_THREAD_LIMIT, OMP_DYNAMIC), since a barrier sized for more would hang.
// Defined in omp_team.cpp, the only translation unit built with OpenMP flags.
class omp_team {
 public:
  static constexpr std::string_view kName = "omp_parallel";

  explicit omp_team(unsigned participants) : participants_(participants) { assert(participants >= 1); }

  unsigned participants() const noexcept { return participants_; }

  template <class Body>
  void run(Body&& body) {
    run_region(std::function<void(unsigned)>(std::ref(body)));
  }

 private:
  void run_region(const std::function<void(unsigned)>& body);
  unsigned participants_;
};

// The team a primitive runs on: specialise for primitives that need their own.
template <class Primitive>
struct team_of {
  using type = std_thread_team;
};
template <class Primitive>
using team_of_t = typename team_of<Primitive>::type;

}  // namespace lockstep::sync
