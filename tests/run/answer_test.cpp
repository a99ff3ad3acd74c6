// The answer of a run (bench/run/answer.hpp) and the comparisons it
// rests on (bench/run/paired_blocks.hpp), on hand-made run books: which
// entries collapse, that each unordered comparison is planned once and read
// the same both ways, and that the combination the answer recommends is the
// one the paired comparisons put first. No timing is measured or asserted.
#include <fmt/core.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "bench/run/answer.hpp"
#include "bench/run/paired_blocks.hpp"
#include "bench/run/run_book.hpp"
#include "tests/support/run_file_entries.hpp"

namespace {

namespace bench = lockstep::bench;

// The answer as the run makes it, from the book's own choices.
bench::run_answer answer_of(const bench::run_book& book, const bench::known_answers& probes, unsigned cpus,
                            const std::string& result_path) {
  return bench::make_answer(book, bench::choose_combinations(book), {probes, cpus, result_path, nullptr, nullptr});
}

std::string step_name(const std::string& sync, const std::string& layout, const std::string& pin, unsigned threads) {
  return "rk4/sync:" + sync + "/layout:" + layout + "/pin:" + pin + "/threads:" + std::to_string(threads);
}

// An rk4 entry with `ns_per_step` in each of three repetitions.
void add_step(bench::run_book& book, const std::string& sync, const std::string& layout, const std::string& pin,
              unsigned threads, double ns_per_step, bool oversubscribed = false, double migrations = 0.0) {
  bench::captured_entry entry;
  entry.name = step_name(sync, layout, pin, threads);
  entry.spec = lockstep::testing::spec_from_old_name(entry.name);
  for (int repetition = 0; repetition < 3; ++repetition)
    entry.repetitions.push_back({{"ns_per_step", ns_per_step},
                                 {"oversubscribed", oversubscribed ? 1.0 : 0.0},
                                 {"migrations_per_kstep", migrations},
                                 {"vs_c2c", 1.0}});
  book.record(std::move(entry));
}

// Measures every planned comparison as pairs whose ratios are all `ratio_of(a, b)`.
template <class RatioOf>
void measure(bench::run_book& book, RatioOf ratio_of) {
  for (const bench::comparison& what : bench::plan_comparisons(book)) {
    bench::paired_result pair;
    pair.what = what;
    const double ratio = ratio_of(what.a, what.b);
    pair.ratios = {ratio * 0.99, ratio, ratio * 1.01, ratio, ratio * 1.005};
    pair.estimate = bench::bootstrap_median(pair.ratios);
    pair.verdict = bench::verdict_of(pair.estimate, book.noise);
    book.pairs.push_back(pair);
  }
}

// Two thread counts on two CPUs: at threads:2 mailbox leads by median,
// seqlock close behind, std_barrier far behind; at threads:4 (oversubscribed)
// a pure spinner takes 20 ms a step.
bench::run_book two_cpu_book() {
  bench::run_book book;
  add_step(book, "mailbox", "per_thread", "compact", 2, 1000.0);
  add_step(book, "mailbox", "packed", "compact", 2, 1100.0);
  add_step(book, "seqlock", "per_thread", "compact", 2, 1040.0);
  add_step(book, "seqlock", "padded64", "compact", 2, 1300.0);
  add_step(book, "std_barrier", "padded64", "compact", 2, 5800.0);
  add_step(book, "mailbox", "per_thread", "compact", 4, 5000.0, true);
  add_step(book, "std_barrier", "per_thread", "compact", 4, 30000.0, true);
  add_step(book, "ck_centralized", "per_thread", "compact", 4, 20'000'000.0, true);
  return book;
}

TEST(Collapse, AnOversubscribedEntryAHundredTimesTheBestIsCollapsedAndOutOfTheRanking) {
  bench::run_book book = two_cpu_book();
  book.collapsed = bench::find_collapsed(book);
  EXPECT_EQ(book.collapsed, (std::set<std::string>{step_name("ck_centralized", "per_thread", "compact", 4)}));
  for (const auto& step : bench::measured_of(book, bench::entry_kind::rk4))
    EXPECT_EQ(book.collapsed.count(step.entry->name), 0u) << step.entry->name;
  for (const auto& what : bench::plan_comparisons(book)) {
    EXPECT_EQ(book.collapsed.count(what.a), 0u) << what.group;
    EXPECT_EQ(book.collapsed.count(what.b), 0u) << what.group;
  }
}

TEST(Collapse, ASlowEntryWithACpuPerThreadIsNotCollapsed) {
  bench::run_book book;
  add_step(book, "mailbox", "per_thread", "compact", 2, 1000.0);
  add_step(book, "win_event_faithful", "per_thread", "compact", 2, 500'000.0);
  EXPECT_TRUE(bench::find_collapsed(book).empty());
}

TEST(PlanComparisons, EachUnorderedPairIsPlannedOnce) {
  bench::run_book book = two_cpu_book();
  book.collapsed = bench::find_collapsed(book);
  std::set<std::pair<std::string, std::string>> seen;
  for (const auto& what : bench::plan_comparisons(book)) {
    const auto unordered = std::minmax(what.a, what.b);
    EXPECT_TRUE(seen.insert(unordered).second) << what.a << " and " << what.b << " are compared twice";
  }
}

TEST(PlanComparisons, NoMigrationPairWhereTheUnpinnedEntryDidNotMigrate) {
  bench::run_book book;
  add_step(book, "mailbox", "per_thread", "compact", 2, 1000.0);
  add_step(book, "mailbox", "per_thread", "none", 2, 1010.0, false, 0.0);
  add_step(book, "seqlock", "per_thread", "compact", 2, 1000.0);
  add_step(book, "seqlock", "per_thread", "none", 2, 1400.0, false, 2.5);
  std::vector<std::string> migrating;
  for (const auto& what : bench::plan_comparisons(book))
    if (what.kind == bench::comparison_kind::migration) migrating.push_back(what.a);
  EXPECT_EQ(migrating, (std::vector<std::string>{step_name("seqlock", "per_thread", "none", 2)}));
}

TEST(AgainstBestOther, TheTwoDirectionsOfOnePairAgree) {
  bench::run_book book = two_cpu_book();
  book.collapsed = bench::find_collapsed(book);
  // seqlock runs 0.9x mailbox side by side: a gain one way, a penalty the other.
  measure(book, [](const std::string& a, const std::string&) { return a.find("seqlock") != std::string::npos ? 0.9 : 5.8; });
  const auto views = bench::against_best_other_views(book, "RK4 step pin:compact threads:2");
  ASSERT_EQ(views.size(), 3u);
  std::map<std::pair<std::string, std::string>, const bench::best_other_view*> by_direction;
  for (const auto& view : views) by_direction[{view.entry->name, view.other->name}] = &view;
  unsigned read_both_ways = 0;  // views whose reverse is listed too: the checks below ran on them
  for (const auto& view : views) {
    const auto back = by_direction.find({view.other->name, view.entry->name});
    if (back == by_direction.end()) continue;
    ++read_both_ways;
    EXPECT_DOUBLE_EQ(view.estimate.median * back->second->estimate.median, 1.0);
    EXPECT_DOUBLE_EQ(view.estimate.low * back->second->estimate.high, 1.0);
    EXPECT_EQ(view.verdict, bench::inverse(back->second->verdict)) << view.entry->name << " against " << view.other->name;
    EXPECT_NE(view.inverted, back->second->inverted);
  }
  // mailbox against seqlock and seqlock against mailbox: without them the loop checks nothing.
  EXPECT_EQ(read_both_ways, 2u);
  EXPECT_EQ(views.front().entry->name, step_name("mailbox", "per_thread", "compact", 2));
  EXPECT_TRUE(views.front().inverted);
  EXPECT_EQ(views.front().verdict, bench::ratio_verdict::penalty);
}

TEST(Answer, RecommendsWhatThePairsPutFirstWhereTheyOverturnTheMedians) {
  bench::run_book book = two_cpu_book();
  book.collapsed = bench::find_collapsed(book);
  measure(book, [](const std::string& a, const std::string&) { return a.find("seqlock") != std::string::npos ? 0.9 : 5.8; });
  const bench::run_answer answer = answer_of(book, {}, 2, "results/x.json");
  ASSERT_EQ(answer.choices.size(), 2u);
  const bench::answer_choice& two = answer.choices[0];
  EXPECT_EQ(two.threads, 2u);
  EXPECT_EQ(two.entry, step_name("seqlock", "per_thread", "compact", 2));
  EXPECT_EQ(two.median_leader, step_name("mailbox", "per_thread", "compact", 2));
  EXPECT_EQ(two.basis, "paired");
  ASSERT_TRUE(two.runner_up);
  EXPECT_EQ(two.runner_up->sync, "mailbox");
  EXPECT_EQ(two.runner_up->verdict, bench::ratio_verdict::penalty);
  EXPECT_LE(answer.lines.size(), bench::kAnswerLines);
}

TEST(Answer, KeepsTheMedianLeaderWhenThePairAgreesOrCannotTell) {
  for (const double seqlock_over_mailbox : {1.3, 1.01}) {
    bench::run_book book = two_cpu_book();
    book.collapsed = bench::find_collapsed(book);
    measure(book, [&](const std::string& a, const std::string&) {
      return a.find("seqlock") != std::string::npos ? seqlock_over_mailbox : 5.8;
    });
    const bench::run_answer answer = answer_of(book, {}, 2, "results/x.json");
    ASSERT_FALSE(answer.choices.empty());
    const bench::answer_choice& two = answer.choices[0];
    EXPECT_EQ(two.entry, step_name("mailbox", "per_thread", "compact", 2)) << seqlock_over_mailbox;
    ASSERT_TRUE(two.runner_up);
    EXPECT_EQ(two.runner_up->sync, "seqlock");
    EXPECT_EQ(two.runner_up->verdict, seqlock_over_mailbox > 1.1 ? bench::ratio_verdict::penalty
                                                                 : bench::ratio_verdict::within_noise);
    ASSERT_TRUE(two.baseline);
    EXPECT_NEAR(two.baseline->estimate.median, 5.8, 0.1);
  }
}

TEST(Answer, RanksByMediansAndSaysSoWithoutPairs) {
  bench::run_book book = two_cpu_book();
  book.collapsed = bench::find_collapsed(book);
  const bench::run_answer answer = answer_of(book, {}, 2, "results/x.json");
  ASSERT_FALSE(answer.choices.empty());
  EXPECT_EQ(answer.choices[0].entry, step_name("mailbox", "per_thread", "compact", 2));
  EXPECT_EQ(answer.choices[0].basis, "medians");
  const std::string text = bench::answer_text(answer);
  EXPECT_NE(text.find("ranked by medians only"), std::string::npos) << text;
  // The file's lines are whole (the terminal's text wraps them).
  std::string lines;
  for (const auto& line : answer.lines) lines += line + "\n";
  EXPECT_NE(lines.find("Collapsed when threads outnumber CPUs (1 entries"), std::string::npos) << lines;
}

TEST(Answer, SaysMigrationWasNotMeasuredWhenNothingMigrated) {
  bench::run_book book;
  add_step(book, "mailbox", "per_thread", "compact", 2, 1000.0);
  add_step(book, "mailbox", "per_thread", "none", 2, 1010.0, false, 0.0);
  const std::string text = bench::answer_text(answer_of(book, {}, 2, "results/x.json"));
  EXPECT_NE(text.find("the OS migrated none of the 1 pin:none entries"), std::string::npos) << text;
}

// One rk4 entry at threads:2 whose repetitions ran in the pace modes given
// (-1: the repetition straddles a change; kNoMode: no trace was analysed),
// 1000 ns a step in mode 0 and 3000 ns in any other.
constexpr int kNoMode = -2;
bench::run_book book_in_modes(const std::vector<int>& modes) {
  bench::run_book book;
  bench::captured_entry entry;
  entry.name = step_name("mailbox", "per_thread", "compact", 2);
  entry.spec = lockstep::testing::spec_from_old_name(entry.name);
  for (const int mode : modes) {
    entry.repetitions.push_back({{"ns_per_step", mode == 0 ? 1000.0 : 3000.0}});
    if (mode != kNoMode) entry.repetitions.back()["pace_mode"] = mode;
  }
  book.record(std::move(entry));
  return book;
}

TEST(Answer, SaysWhenTheSpreadComesFromTheMachinesPace) {
  struct known {
    std::vector<int> modes;
    std::size_t paces;
    bool straddles;
    const char* words;  // after the spread; empty: nothing after it
  };
  for (const known& expected : {known{{0, 0, 0, 0, 0}, 1, false, ""}, known{{0, 0, 1, 0, 0}, 2, false, " over 2 paces of the machine: uncertain"},
                              known{{0, -1, 0, 0, 0}, 1, true, ", straddles a pace change"},
                              known{{0, 1, 2, -1, 0}, 3, true, " over 3 paces of the machine: uncertain"},
                              known{{kNoMode, kNoMode, kNoMode}, 0, false, ""}}) {
    const bench::run_book book = book_in_modes(expected.modes);
    const bench::run_answer answer = answer_of(book, {}, 2, "results/x.json");
    ASSERT_EQ(answer.choices.size(), 1u);
    const bench::answer_choice& choice = answer.choices.front();
    EXPECT_EQ(choice.paces, expected.paces);
    EXPECT_EQ(choice.straddles_pace_change, expected.straddles);
    const std::string spread = fmt::format("a step (+-{:.1f} %{})", choice.spread_pct(), expected.words);
    EXPECT_NE(bench::answer_text(answer).find(spread), std::string::npos) << spread << "\n"
                                                                            << bench::answer_text(answer);
    const nlohmann::json json = bench::answer_json(answer);
    EXPECT_EQ(json["recommendations"][0]["paces"], expected.paces);
    EXPECT_EQ(json["recommendations"][0]["straddles_pace_change"], expected.straddles);
  }
}

TEST(Answer, StaysWithinItsLinesForAManyThreadMatrix) {
  bench::run_book book;
  for (unsigned threads = 2; threads <= 64; threads += 2)
    for (const char* pin : {"compact", "none"}) add_step(book, "mailbox", "per_thread", pin, threads, 1000.0 * threads);
  const bench::run_answer answer = answer_of(book, {}, 64, "results/x.json");
  EXPECT_EQ(answer.lines.size(), bench::kAnswerLines);
  EXPECT_NE(bench::answer_text(answer).find("more lines of choices"), std::string::npos);
  EXPECT_EQ(answer.choices.size(), 64u);
}

// The known answers of a run whose probe measured each access pattern:
// `figures` holds (pattern name, median, low, high) in any order.
bench::known_answers false_sharing_answers(const std::vector<std::tuple<std::string, double, double, double>>& figures,
                                           const std::string& relation = "shared L3") {
  bench::known_answers answers;
  answers.false_sharing_relation = relation;
  for (const auto& [pattern, median, low, high] : figures) {
    const bench::ratio_estimate estimate{median, low, high};
    answers.false_sharing.push_back({pattern, "0,1", 8, 128, estimate, bench::verdict_of(estimate), 9});
  }
  return answers;
}

// A book with one false-sharing pair: packed against padded64 for one primitive.
bench::run_book false_sharing_book(double packed_over_padded) {
  bench::run_book book;
  add_step(book, "futex_spin", "packed", "compact", 2, 1000.0 * packed_over_padded);
  add_step(book, "futex_spin", "padded64", "compact", 2, 1000.0);
  measure(book, [&](const std::string& a, const std::string&) {
    return a.find("packed") != std::string::npos ? packed_over_padded : 1.0 / packed_over_padded;
  });
  return book;
}

std::vector<std::string> lines_from(const std::string& first_words, const bench::run_answer& answer) {
  std::vector<std::string> lines;
  bool in = false;
  for (const auto& line : answer.lines) {
    if (line.rfind(first_words, 0) == 0) in = true;
    else if (in && line.rfind("  ", 0) != 0) break;
    if (in) lines.push_back(line);
  }
  return lines;
}

// The lines as one text, each without its indent, joined by spaces (a
// fact's lines continue one another).
std::string as_text(const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& line : lines) {
    if (!text.empty()) text += ' ';
    text += line.substr(line.find_first_not_of(' '));
  }
  return text;
}

TEST(Answer, StatesFalseSharingPerPatternAndWhichTheStepsLayoutsExercise) {
  const bench::run_book book = false_sharing_book(1.0);
  const bench::run_answer answer = answer_of(
      book,
      false_sharing_answers({{"plain_store", 1.01, 0.97, 1.04},
                             {"atomic_rmw", 4.61, 4.12, 4.90},
                             {"seq_cst_store", 4.43, 4.10, 4.71},
                             {"writer_beside_reader", 1.02, 0.98, 1.04}}),
      2, "results/x.json");
  const std::vector<std::string> lines = lines_from("False sharing", answer);
  std::string joined;
  for (const auto& line : lines) {
    EXPECT_FALSE(line.ends_with("...")) << line;
    joined += line + "\n";
  }
  // The terminal wraps each line within its width, never inside an
  // interval; its pieces, put back together, are the line.
  std::string terminal;
  for (const auto& line : lines) {
    const std::string text = bench::wrapped(line, 120);
    std::string rejoined;
    for (std::size_t start = 0; start < text.size();) {
      const std::size_t end = text.find('\n', start);
      EXPECT_LE(end - start, 120u) << text.substr(start, end - start);
      // A continuation's indent is the wrap's, not the line's.
      const std::size_t words = rejoined.empty() ? start : text.find_first_not_of(' ', start);
      if (!rejoined.empty()) rejoined += ' ';
      rejoined.append(text, words, end - words);
      start = end + 1;
    }
    EXPECT_EQ(rejoined, line);
    terminal += text;
  }
  // Each figure whole on one line of the file, the paying ones first; on the
  // terminal each interval whole on one line.
  const std::vector<std::string> in_order{"atomic read-modify-writes 4.61x [4.12, 4.90] penalty",
                                          "seq_cst stores 4.43x [4.10, 4.71] penalty",
                                          "plain stores 1.01x [0.97, 1.04] within noise",
                                          "a writer beside a reader 1.02x [0.98, 1.04] within noise"};
  std::size_t previous = 0;
  for (const auto& figure : in_order) {
    const std::size_t at = joined.find(figure);
    ASSERT_NE(at, std::string::npos) << figure << "\n" << joined;
    const std::string interval = figure.substr(figure.find('['), figure.find(']') - figure.find('[') + 1);
    EXPECT_NE(terminal.find(interval), std::string::npos) << interval << "\n" << terminal;
    EXPECT_GE(at, previous) << figure;
    previous = at;
  }
  const std::string text = as_text(lines);
  EXPECT_NE(text.find("this core hides it for plain stores and a writer beside a reader"), std::string::npos) << text;
  EXPECT_NE(text.find("the step's layouts exercise plain stores and a writer beside a reader"), std::string::npos)
      << text;
  EXPECT_NE(text.find("in the step: 0 of 1 primitive/placement/thread groups showed a penalty"), std::string::npos)
      << text;
  EXPECT_NE(text.find("(words 8 B against 128 B apart, per access; CPUs 0,1, shared L3, 9 pairs):"), std::string::npos) << text;
  // The file: every pattern, and the plain stores' figure where older files had the only one.
  const nlohmann::json json = bench::answer_json(answer);
  ASSERT_EQ(json["false_sharing_patterns"].size(), 4u);
  EXPECT_EQ(json["false_sharing_probe"]["median"], 1.01);
  EXPECT_EQ(json["false_sharing_probe"]["verdict"], "within noise");
  EXPECT_EQ(json["false_sharing_patterns"][1]["pattern"], "atomic_rmw");
  EXPECT_EQ(json["false_sharing_patterns"][1]["verdict"], "penalty");
  EXPECT_EQ(json["false_sharing_patterns"][1]["words"], "atomic read-modify-writes");
  EXPECT_EQ(json["false_sharing_patterns"][1]["in_step_layouts"], false);
  EXPECT_EQ(json["false_sharing_patterns"][1]["cpus_relation"], "shared L3");
}

TEST(Answer, WhenNoPatternPaysItSaysWhatThatMeansWithTheEvidence) {
  bench::run_book book = false_sharing_book(1.0);
  const bench::run_answer answer = answer_of(
      book,
      false_sharing_answers({{"plain_store", 1.0, 0.98, 1.02},
                             {"atomic_rmw", 1.01, 0.99, 1.03},
                             {"seq_cst_store", 0.99, 0.97, 1.02},
                             {"writer_beside_reader", 1.0, 0.97, 1.03}}),
      2, "results/x.json");
  const std::string text = as_text(lines_from("False sharing", answer));
  EXPECT_NE(text.find("no pattern pays: the two CPUs act as if they shared one core's cache"), std::string::npos)
      << text;
  EXPECT_NE(text.find("hwloc calls CPUs 0,1 shared L3"), std::string::npos) << text;
}

TEST(Answer, NamesThePatternsAFileDidNotMeasure) {
  // A file from before the patterns: the plain stores' figure only.
  const bench::run_answer answer = answer_of(
      false_sharing_book(1.0), false_sharing_answers({{"plain_store", 3.24, 1.25, 3.61}}, ""), 2, "results/x.json");
  const std::string text = as_text(lines_from("False sharing", answer));
  EXPECT_NE(text.find("plain stores 3.24x [1.25, 3.61] penalty: every pattern measured pays; not measured: atomic "
                      "read-modify-writes, seq_cst stores and a writer beside a reader"),
            std::string::npos)
      << text;
}

TEST(Answer, SaysWhyFalseSharingWasNotMeasured) {
  bench::known_answers answers;
  answers.false_sharing_unavailable = "fewer than two CPUs to pin two threads on";
  const bench::run_answer answer = answer_of(false_sharing_book(1.0), answers, 2, "results/x.json");
  EXPECT_NE(bench::answer_text(answer).find(
                "False sharing: probe unavailable (fewer than two CPUs to pin two threads on)"),
            std::string::npos);
  EXPECT_TRUE(bench::answer_json(answer)["false_sharing_probe"].is_null());
  EXPECT_TRUE(bench::answer_json(answer)["false_sharing_patterns"].empty());
}

}  // namespace

namespace {

// An rk4 entry whose repetitions measured these steps.
void add_spread_step(bench::run_book& book, const std::string& pin, unsigned threads,
                     const std::vector<double>& steps) {
  bench::captured_entry entry;
  entry.name = step_name("mailbox", "per_thread", pin, threads);
  entry.spec = lockstep::testing::spec_from_old_name(entry.name);
  for (double step : steps)
    entry.repetitions.push_back({{"ns_per_step", step}, {"oversubscribed", threads > 2 ? 1.0 : 0.0}, {"vs_c2c", 1.0}});
  book.record(std::move(entry));
}

}  // namespace

// No pair compares choices of different placements or thread counts: the
// best by median is named with every choice whose repetitions overlap its
// own, as a tie, in the line and in the JSON; one whose repetitions lie
// apart is not.
TEST(AnswerFirst, ChoicesTheRunDoesNotSeparateAreNamedAsATie) {
  bench::run_book book;
  add_spread_step(book, "compact", 2, {900.0, 1000.0, 1100.0});
  add_spread_step(book, "none", 2, {950.0, 1050.0, 1150.0});
  add_spread_step(book, "compact", 4, {4900.0, 5000.0, 5100.0});
  const bench::run_answer answer = answer_of(book, bench::known_answers{}, 2, "results/x.json");
  ASSERT_TRUE(answer.best.has_value());
  EXPECT_EQ(answer.best->pin, lockstep::platform::placement::compact);
  ASSERT_EQ(answer.best->level.size(), 1u);
  EXPECT_EQ(answer.best->level[0].pin, lockstep::platform::placement::none);
  EXPECT_EQ(answer.best->level[0].threads, 2u);
  const auto first = std::find_if(answer.lines.begin(), answer.lines.end(),
                                  [](const std::string& line) { return line.rfind("Best here:", 0) == 0; });
  ASSERT_NE(first, answer.lines.end());
  EXPECT_NE(first->find("tied with threads:2 pin:none (1.05 us): their repetitions overlap and no pair compared them"),
            std::string::npos)
      << *first;
  EXPECT_EQ(first->find("threads:4"), std::string::npos) << *first;
  const nlohmann::json json = bench::answer_json(answer);
  ASSERT_EQ(json["answer"]["level"].size(), 1u);
  EXPECT_EQ(json["answer"]["level"][0]["pin"], "none");
}

TEST(AnswerFirst, AChoiceWhoseRepetitionsLieApartIsNoTie) {
  bench::run_book book;
  add_spread_step(book, "compact", 2, {900.0, 1000.0, 1100.0});
  add_spread_step(book, "none", 2, {1500.0, 1600.0, 1700.0});
  const bench::run_answer answer = answer_of(book, bench::known_answers{}, 2, "results/x.json");
  ASSERT_TRUE(answer.best.has_value());
  EXPECT_TRUE(answer.best->level.empty());
  EXPECT_EQ(bench::answer_json(answer)["answer"]["level"], nlohmann::json::array());
}

// The overlap is of the repetitions themselves: a choice with one slow
// repetition has a range mostly above its median (a fresh run's 4 threads on
// 2 CPUs: 5.53-15.76 us about a median of 5.77 us, "+-88.7 %"), and was
// called tied with a best of 0.30-1.03 us when the range was taken as the
// median -+ half of it.
TEST(AnswerFirst, OneSlowRepetitionDoesNotTieAChoiceWithAFasterOne) {
  bench::run_book book;
  add_spread_step(book, "compact", 2, {301.0, 695.0, 922.0, 957.0, 1032.0});
  add_spread_step(book, "compact", 4, {5529.0, 5541.0, 5770.0, 6293.0, 15760.0});
  const bench::run_answer answer = answer_of(book, bench::known_answers{}, 2, "results/x.json");
  ASSERT_TRUE(answer.best.has_value());
  EXPECT_EQ(answer.best->threads, 2u);
  EXPECT_TRUE(answer.best->level.empty());
}
