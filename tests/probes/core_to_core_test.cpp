// The ping-pong measurement core: it returns the samples asked for, each a
// finite positive one-way latency, and rejects bad requests. No latency value
// is asserted (the machine may be loaded).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "bench/probes/core_to_core.hpp"
#include "tests/support/watchdog.hpp"

namespace {

using lockstep::bench::c2c::measure_pair;
using lockstep::bench::c2c::method;
using lockstep::bench::c2c::pair_request;

void expect_samples(method how) {
  if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "needs two CPUs";
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "c2c ping-pong");
  pair_request request;
  request.cpu_a = 0;
  request.cpu_b = 1;
  request.how = how;
  request.samples = 20;
  request.rounds_per_sample = 10;
  request.warmup_rounds = 10;
  const auto samples = measure_pair(request);
  ASSERT_EQ(samples.size(), 20u);
  for (double ns : samples) {
    EXPECT_TRUE(std::isfinite(ns));
    EXPECT_GT(ns, 0.0);
  }
}

TEST(CoreToCore, CasReturnsEverySample) { expect_samples(method::cas); }
TEST(CoreToCore, StoreLoadReturnsEverySample) { expect_samples(method::store_load); }
TEST(CoreToCore, StageReturnsEverySample) { expect_samples(method::stage); }

TEST(CoreToCore, RejectsBadRequests) {
  pair_request same;
  same.cpu_a = same.cpu_b = 0;
  EXPECT_THROW(measure_pair(same), std::invalid_argument);
  pair_request negative;
  negative.cpu_a = -1;
  EXPECT_THROW(measure_pair(negative), std::invalid_argument);
  pair_request empty;
  empty.samples = 0;
  EXPECT_THROW(measure_pair(empty), std::invalid_argument);
}

TEST(CoreToCore, ReportsACpuItCannotUse) {
  lockstep::testing::watchdog guard(std::chrono::seconds(30 * lockstep::testing::kSlowdown), "c2c with an offline CPU");
  pair_request request;
  request.cpu_a = 0;
  request.cpu_b = CPU_SETSIZE - 1;  // never online on this machine
  EXPECT_THROW(measure_pair(request), std::runtime_error);
  request.cpu_a = CPU_SETSIZE - 1;
  request.cpu_b = 0;
  EXPECT_THROW(measure_pair(request), std::runtime_error);
}

}  // namespace
