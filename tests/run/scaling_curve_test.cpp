// The scaling curve of `lockstep run --scaling` (bench/run/scaling.hpp),
// on hand-made run books with known answers: which entries make the curve,
// which layout stands for a primitive at each count, which primitive "scales
// best", and when the summary must say that the run does not separate it from
// the next one (their repetitions' ranges overlap).
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "bench/run/reporters.hpp"
#include "bench/run/run_book.hpp"
#include "bench/run/scaling.hpp"
#include "tests/support/run_file_entries.hpp"

namespace {

namespace bench = lockstep::bench;

// An rk4 entry whose repetitions read these sync times per stage (and a step
// time ten times larger, so that a mix-up of the counters shows).
bench::captured_entry rk4_entry(const std::string& name, const std::vector<double>& sync_ns_per_stage,
                                bool oversubscribed = false) {
  bench::captured_entry entry;
  entry.name = name;
  entry.spec = lockstep::testing::spec_from_old_name(name);
  for (const double value : sync_ns_per_stage)
    entry.repetitions.push_back({{"sync_ns_per_stage", value},
                                 {"ns_per_step", 10.0 * value},
                                 {"oversubscribed", oversubscribed ? 1.0 : 0.0}});
  return entry;
}

const bench::scaling_point* point_of(const bench::scaling_curve& curve, const std::string& sync, unsigned threads) {
  for (const auto& point : curve.points)
    if (point.sync == sync && point.threads == threads) return &point;
  return nullptr;
}

// Two primitives at 2 and 8 threads; "slow" has two layouts at 8 threads.
bench::run_book two_primitives(const std::vector<double>& fast_at_8, const std::vector<double>& slow_at_8) {
  bench::run_book book;
  book.record(rk4_entry("rk4/serial", {20.0}));
  book.record(rk4_entry("rk4/model:chain4/serial", {40.0}));
  book.record(rk4_entry("rk4/sync:fast/layout:per_thread/pin:compact/threads:2", {20.0, 21.0, 22.0}));
  book.record(rk4_entry("rk4/sync:slow/layout:packed/pin:compact/threads:2", {50.0, 51.0, 52.0}));
  book.record(rk4_entry("rk4/model:chain4/sync:fast/layout:per_thread/pin:compact/threads:8", fast_at_8, true));
  book.record(rk4_entry("rk4/model:chain4/sync:slow/layout:packed/pin:compact/threads:8", slow_at_8, true));
  book.record(rk4_entry("rk4/model:chain4/sync:slow/layout:padded64/pin:compact/threads:8",
                        {slow_at_8[0] * 3, slow_at_8[1] * 3, slow_at_8[2] * 3}, true));
  return book;
}

TEST(ScalingCurve, EachPrimitiveOnItsBestLayoutAtEachCountAndTheSerialEntriesLeftOut) {
  const auto curve = bench::scaling_of(two_primitives({2000.0, 2100.0, 2200.0}, {5000.0, 5100.0, 5200.0}));
  EXPECT_EQ(curve.pin, "compact");
  EXPECT_EQ(curve.counter, "sync_ns_per_stage");
  EXPECT_EQ(curve.threads, (std::vector<unsigned>{2, 8}));
  ASSERT_EQ(curve.points.size(), 4U);
  const auto* slow = point_of(curve, "slow", 8);
  ASSERT_NE(slow, nullptr);
  EXPECT_EQ(slow->layout, "packed");
  EXPECT_EQ(slow->model, "chain4");
  EXPECT_DOUBLE_EQ(slow->sync_ns_per_stage, 5100.0);
  EXPECT_DOUBLE_EQ(slow->lowest, 5000.0);
  EXPECT_DOUBLE_EQ(slow->highest, 5200.0);
  EXPECT_TRUE(slow->oversubscribed);
  EXPECT_FALSE(point_of(curve, "fast", 2)->oversubscribed);
}

TEST(ScalingCurve, TheBestIsTheLowestAtTheLargestCountAndItsLeadIsSaidSeparated) {
  const auto curve = bench::scaling_of(two_primitives({2000.0, 2100.0, 2200.0}, {5000.0, 5100.0, 5200.0}));
  ASSERT_TRUE(curve.best.has_value());
  EXPECT_EQ(*curve.best, "fast");
  const std::string summary = bench::render_scaling(curve);
  EXPECT_NE(summary.find("Scales best: fast (2.10 us at 8 threads, oversubscribed"), std::string::npos) << summary;
  EXPECT_NE(summary.find("next slow at 5.10 us, 2.43x"), std::string::npos) << summary;
  EXPECT_EQ(summary.find("does not separate"), std::string::npos) << summary;
}

TEST(ScalingCurve, OverlappingRangesAreSaidNotSeparated) {
  const auto curve = bench::scaling_of(two_primitives({2000.0, 2100.0, 2600.0}, {2150.0, 2200.0, 2300.0}));
  ASSERT_TRUE(curve.best.has_value());
  EXPECT_EQ(*curve.best, "fast");
  const std::string summary = bench::render_scaling(curve);
  EXPECT_NE(summary.find("this run does not separate them"), std::string::npos) << summary;
}

TEST(ScalingCurve, APrimitiveMissingAtACountCannotScaleBest) {
  auto book = two_primitives({9000.0, 9100.0, 9200.0}, {5000.0, 5100.0, 5200.0});
  // Lowest at 8 threads, but never measured at 2: no curve to judge.
  book.record(rk4_entry("rk4/model:chain4/sync:only_at_8/layout:per_thread/pin:compact/threads:8", {10.0, 11.0, 12.0}));
  const auto curve = bench::scaling_of(book);
  ASSERT_TRUE(curve.best.has_value());
  EXPECT_EQ(*curve.best, "slow");
}

TEST(ScalingCurve, TheJsonCarriesEachPointWithItsRange) {
  const auto curve = bench::scaling_of(two_primitives({2000.0, 2100.0, 2200.0}, {5000.0, 5100.0, 5200.0}));
  const auto json = bench::scaling_json(curve, 23.0);
  EXPECT_EQ(json["counter"], "sync_ns_per_stage");
  EXPECT_EQ(json["best"], "fast");
  EXPECT_DOUBLE_EQ(json["c2c_one_way_ns"].get<double>(), 23.0);
  ASSERT_EQ(json["points"].size(), 4U);
  bool found = false;
  for (const auto& point : json["points"]) {
    if (point["sync"] == "fast" && point["threads"] == 2) {
      found = true;
      EXPECT_EQ(point["model"], "two_mass");
      EXPECT_DOUBLE_EQ(point["repetitions_min"].get<double>(), 20.0);
      EXPECT_DOUBLE_EQ(point["repetitions_max"].get<double>(), 22.0);
    }
  }
  EXPECT_TRUE(found);
}

TEST(ScalingCurve, OneThreadCountIsNoCurve) {
  bench::run_book book;
  book.record(rk4_entry("rk4/sync:fast/layout:per_thread/pin:compact/threads:2", {20.0}));
  const auto curve = bench::scaling_of(book);
  EXPECT_FALSE(curve.best.has_value());
  EXPECT_EQ(bench::render_scaling(curve), "");
}

}  // namespace
