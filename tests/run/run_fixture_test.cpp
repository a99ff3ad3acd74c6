// One real run file, read back through the code that wrote its figures: for
// every paired comparison of tests/fixtures/run/quick-pairs.json (a
// `lockstep run --quick` file, written by the binary, never edited), the
// median, interval and verdict recomputed from its ratios by the harness's
// own calls (bench::bootstrap_median, bench::verdict_of: paired_ratio.hpp)
// are the file's to the last bit, and the summary `lockstep run --verbose`
// prints over a run book rebuilt from the file shows each of them.
// reports/tests/test_run_fixture.py holds reports/lockstep_reports/common/statistics.py
// and the figures compare and report print to the same file: a change of the
// rule (median, quantile, draws, verdict edge) on one side alone fails one of
// the two. No timing is measured or asserted.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <fmt/core.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "bench/probes/falseshare.hpp"
#include "bench/run/answer.hpp"
#include "bench/run/paired_blocks.hpp"
#include "bench/results/paired_ratio.hpp"
#include "bench/run/reporters.hpp"
#include "bench/run/run_book.hpp"
#include "bench/run/run_result.hpp"
#include "bench/run/summary.hpp"
#include "tests/support/run_file_entries.hpp"
#include "platform/statistics.hpp"

namespace {

namespace bench = lockstep::bench;
namespace platform = lockstep::platform;

const nlohmann::json& fixture() {
  static const nlohmann::json document = [] {
    std::ifstream in(std::string(LOCKSTEP_SOURCE_DIR) + "/tests/fixtures/run/quick-pairs.json");
    return nlohmann::json::parse(in);
  }();
  return document;
}

bench::comparison_kind kind_named(const std::string& name) {
  for (const auto kind : {bench::comparison_kind::false_sharing, bench::comparison_kind::migration,
                          bench::comparison_kind::against_best_other})
    if (bench::to_string(kind) == name) return kind;
  ADD_FAILURE() << "a comparison of unknown kind " << name;
  return bench::comparison_kind::false_sharing;
}

// A pair of the file as measure_pairs left it, its estimate and verdict
// recomputed from its ratios as finish_comparison computes them.
bench::paired_result recomputed(const nlohmann::json& pair) {
  bench::paired_result result;
  result.what = {kind_named(pair.at("comparison").get<std::string>()), pair.at("group").get<std::string>(),
                 pair.at("a").get<std::string>(), pair.at("b").get<std::string>()};
  result.ratios = pair.at("ratios").get<std::vector<double>>();
  result.modes = pair.at("modes").get<std::vector<int>>();
  result.block_ms = pair.at("block_ms").get<double>();
  result.budget_cut = pair.value("budget_cut", false);
  result.estimate = bench::bootstrap_median(result.ratios);
  result.verdict = bench::verdict_of(result.estimate, pair.at("noise").get<double>());
  return result;
}

// The file's answer: "lockstep_answer", or in files written before that
// name (the fixture among them) "lockstep_headline".
const nlohmann::json& answer_in(const nlohmann::json& file) {
  return file.contains("lockstep_answer") ? file.at("lockstep_answer") : file.at("lockstep_headline");
}

// The answer as the run makes it, from the book's own choices.
bench::run_answer answer_of(const bench::run_book& book, const bench::known_answers& probes, unsigned cpus,
                            const std::string& result_path) {
  return bench::make_answer(book, bench::choose_combinations(book), {probes, cpus, result_path, nullptr, nullptr});
}

// The run book the run kept: every entry's repetitions (the file's iteration
// rows, their counters), the pairs recomputed, the noise band and the
// collapsed entries. The answer is not made here: its lines are the file's
// (checked below against the pairs), and its probes are not in the book.
bench::run_book book_of(const nlohmann::json& file) {
  // Google Benchmark's own fields of a row; every other number is a counter.
  static const std::set<std::string> own = {"family_index", "per_family_instance_index", "repetitions",
                                            "repetition_index", "threads", "iterations", "real_time", "cpu_time"};
  std::vector<bench::captured_entry> entries;
  for (const auto& row : file.at("benchmarks")) {
    if (row.at("run_type").get<std::string>() != "iteration") continue;
    const std::string name = row.at("name").get<std::string>();
    if (entries.empty() || entries.back().name != name) {
      bench::captured_entry entry;
      entry.name = name;
      entry.spec = lockstep::testing::spec_of_row(row);
      entries.push_back(std::move(entry));
    }
    std::map<std::string, double> counters;
    for (const auto& [key, value] : row.items())
      if (value.is_number() && own.count(key) == 0) counters[key] = value.get<double>();
    if (row.value("error_occurred", false)) {
      // As the run's reporter keeps it (reporters.cpp): a stopped repetition
      // is counted, the entry skipped only when none was measured.
      if (entries.back().stop_reason.empty()) entries.back().stop_reason = row.value("error_message", std::string("error"));
      ++entries.back().stopped_repetitions;
      continue;
    }
    entries.back().repetitions.push_back(std::move(counters));
  }
  for (auto& entry : entries)
    if (entry.repetitions.empty() && entry.stopped_repetitions > 0) {
      entry.error = entry.stop_reason;
      entry.stop_reason.clear();
      entry.stopped_repetitions = 0;
    }
  bench::run_book book;
  for (auto& entry : entries) book.record(std::move(entry));
  // Google Benchmark's context holds strings: "23.2".
  book.clock_read_ns = std::stod(file.at("context").at("clock_read_ns").get<std::string>());
  for (const auto& pair : file.at("lockstep_pairs")) {
    book.pairs.push_back(recomputed(pair));
    book.noise = pair.at("noise").get<double>();
  }
  for (const auto& name : answer_in(file).at("collapsed")) book.collapsed.insert(name.get<std::string>());
  return book;
}

// "1.24x [1.17, 1.33] penalty": how the summary and the answer print a pair.
std::string figure(double median, double low, double high, std::string_view verdict) {
  return fmt::format("{:.2f}x [{:.2f}, {:.2f}] {}", median, low, high, verdict);
}

TEST(RunFixture, HoldsPairsOfEveryKindAndBothKindsOfVerdict) {
  std::set<std::string> kinds;
  std::set<std::string> verdicts;
  for (const auto& pair : fixture().at("lockstep_pairs")) {
    kinds.insert(pair.at("comparison").get<std::string>());
    verdicts.insert(pair.at("verdict").get<std::string>());
  }
  EXPECT_EQ(kinds, (std::set<std::string>{"false_sharing", "migration", "against_best_other"}));
  EXPECT_TRUE(verdicts.count("penalty") + verdicts.count("gain") > 0);
  EXPECT_TRUE(verdicts.count("within noise") + verdicts.count("unsure") > 0);
}

TEST(RunFixture, EveryPairsMedianIntervalAndVerdictAreTheFilesToTheLastBit) {
  ASSERT_FALSE(fixture().at("lockstep_pairs").empty());
  for (const auto& pair : fixture().at("lockstep_pairs")) {
    SCOPED_TRACE(pair.at("a").get<std::string>() + " / " + pair.at("b").get<std::string>());
    // The file's interval is at the harness's confidence (kConfidence); the
    // resamples and seed are the harness's defaults, which the file does not carry.
    EXPECT_EQ(pair.at("confidence").get<double>(), bench::kConfidence);
    const bench::paired_result result = recomputed(pair);
    EXPECT_EQ(result.estimate.median, pair.at("median").get<double>());
    EXPECT_EQ(result.estimate.low, pair.at("ci_low").get<double>());
    EXPECT_EQ(result.estimate.high, pair.at("ci_high").get<double>());
    EXPECT_EQ(bench::to_string(result.verdict), pair.at("verdict").get<std::string>());
    // The verdict of the file's own interval, by the one rule.
    EXPECT_EQ(platform::to_string(platform::verdict_of(pair.at("ci_low").get<double>(),
                                                       pair.at("ci_high").get<double>(),
                                                       pair.at("noise").get<double>())),
              pair.at("verdict").get<std::string>());
  }
}

TEST(RunFixture, TheBookRebuiltFromTheFilePlansTheFilesComparisons) {
  const bench::run_book book = book_of(fixture());
  std::set<std::tuple<std::string, std::string, std::string, std::string>> planned;
  for (const bench::comparison& what : bench::plan_comparisons(book))
    planned.emplace(std::string(bench::to_string(what.kind)), what.group, what.a, what.b);
  std::set<std::tuple<std::string, std::string, std::string, std::string>> measured;
  for (const auto& pair : fixture().at("lockstep_pairs"))
    measured.emplace(pair.at("comparison").get<std::string>(), pair.at("group").get<std::string>(),
                     pair.at("a").get<std::string>(), pair.at("b").get<std::string>());
  EXPECT_EQ(planned, measured);
}

TEST(RunFixture, TheSummaryPrintsEachPairsFigureFromTheFile) {
  bench::run_result result;
  result.book = book_of(fixture());
  const std::string summary = bench::render_summary(result, "quick-pairs.json", /*verbose=*/true);
  std::vector<std::string> lines;
  std::istringstream stream(summary);
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  // A line that holds every one of `parts`, the first at its start.
  const auto printed = [&](const std::vector<std::string>& parts) {
    for (const auto& line : lines) {
      bool all = line.rfind(parts.front(), 0) == 0;
      for (const auto& part : parts) all = all && line.find(part) != std::string::npos;
      if (all) return true;
    }
    return false;
  };
  std::set<std::string> groups_seen;
  for (const auto& pair : fixture().at("lockstep_pairs")) {
    const std::string a = pair.at("a").get<std::string>();
    const std::string b = pair.at("b").get<std::string>();
    const std::string group = pair.at("group").get<std::string>();
    SCOPED_TRACE(a + " / " + b);
    const double median = pair.at("median").get<double>();
    const double low = pair.at("ci_low").get<double>();
    const double high = pair.at("ci_high").get<double>();
    const std::string verdict = pair.at("verdict").get<std::string>();
    if (pair.at("comparison") != "against_best_other") {
      // "  sync:futex_spin pin:compact threads:4   packed/padded64 (...): 1.01x [0.98, 1.10] unsure (6 pairs)"
      EXPECT_TRUE(printed({"  " + group + " ", figure(median, low, high, verdict)})) << summary;
      continue;
    }
    // "    std_barrier   13.6 us (packed)  vs futex_spin   1.24x [1.17, 1.33] penalty (6 pairs)"
    const std::string sync_a = lockstep::testing::spec_from_old_name(a).sync;
    const std::string sync_b = lockstep::testing::spec_from_old_name(b).sync;
    EXPECT_TRUE(printed({"    " + sync_a + " ", " vs " + sync_b + " ", figure(median, low, high, verdict)})) << summary;
    // The group's first pair is the runner-up's against the leader: the
    // leader's line is that pair inverted.
    if (groups_seen.insert(group).second) {
      const platform::verdict file_verdict =
          platform::verdict_of(low, high, pair.at("noise").get<double>());  // the file's, as the rule reads it
      const bench::ratio_estimate inverted = bench::inverse(bench::ratio_estimate{median, low, high});
      EXPECT_TRUE(printed({"    " + sync_b + " ", " vs " + sync_a + " ",
                           figure(inverted.median, inverted.low, inverted.high,
                                  bench::to_string(bench::inverse(file_verdict))),
                           "the runner-up's pair inverted"}))
          << summary;
    }
  }
}

// The answer (the summary's last lines, the report's first) prints paired
// figures: each is a pair's, read either way round (the group's leader has
// its pair with the runner-up inverted: paired_ratio.hpp, inverse), or the
// false-sharing probe's, whose verdict is the rule's.
TEST(RunFixture, EveryFigureOfTheAnswerIsAPairsOrTheProbes) {
  std::set<std::string> known;
  for (const auto& pair : fixture().at("lockstep_pairs")) {
    const bench::paired_result result = recomputed(pair);
    known.insert(figure(result.estimate.median, result.estimate.low, result.estimate.high,
                        bench::to_string(result.verdict)));
    const bench::ratio_estimate inverted = bench::inverse(result.estimate);
    known.insert(
        figure(inverted.median, inverted.low, inverted.high, bench::to_string(bench::inverse(result.verdict))));
  }
  const auto& written = answer_in(fixture());
  // The probe's figures: the plain stores' (false_sharing_probe) and, in
  // files that have them, every pattern's.
  std::vector<nlohmann::json> probe_figures;
  if (const auto& probe = written.at("false_sharing_probe"); !probe.is_null()) probe_figures.push_back(probe);
  for (const auto& probe : written.value("false_sharing_patterns", nlohmann::json::array())) probe_figures.push_back(probe);
  for (const auto& probe : probe_figures) {
    const double low = probe.at("ci_low").get<double>();
    const double high = probe.at("ci_high").get<double>();
    EXPECT_EQ(platform::to_string(platform::verdict_of(low, high, bench::kDefaultNoise)),
              probe.at("verdict").get<std::string>());
    known.insert(figure(probe.at("median").get<double>(), low, high, probe.at("verdict").get<std::string>()));
  }
  const std::regex paired_figure(R"(\d+\.\d\dx \[\d+\.\d\d, \d+\.\d\d\] (penalty|gain|within noise|unsure))");
  std::size_t found = 0;
  for (const auto& line_json : written.at("lines")) {
    const std::string line = line_json.get<std::string>();
    for (auto match = std::sregex_iterator(line.begin(), line.end(), paired_figure); match != std::sregex_iterator();
         ++match) {
      ++found;
      EXPECT_EQ(known.count(match->str()), 1u) << match->str() << " in: " << line;
    }
  }
  EXPECT_GT(found, 0u);
}

// The probes of the file's answer, as the run measured them: every access
// pattern's false sharing where the file has them, else (a file from before
// the patterns) the plain stores' figure, false_sharing_probe.
bench::false_sharing_probe false_sharing_of(const nlohmann::json& probe, const std::string& pattern) {
  bench::false_sharing_probe figure;
  figure.pattern = pattern;
  figure.cpus = probe.at("cpus").get<std::string>();
  figure.sharing_stride = probe.at("sharing_stride_bytes").get<std::size_t>();
  figure.apart_stride = probe.at("apart_stride_bytes").get<std::size_t>();
  figure.estimate = {probe.at("median").get<double>(), probe.at("ci_low").get<double>(),
                     probe.at("ci_high").get<double>()};
  figure.verdict = bench::verdict_of(figure.estimate, bench::kDefaultNoise);
  figure.pairs = probe.at("pairs").get<std::size_t>();
  return figure;
}

bench::known_answers probes_of(const nlohmann::json& file) {
  bench::known_answers probes;
  const auto& written = answer_in(file);
  if (written.contains("false_sharing_patterns")) {
    for (const auto& probe : written.at("false_sharing_patterns")) {
      probes.false_sharing.push_back(false_sharing_of(probe, probe.at("pattern").get<std::string>()));
      probes.false_sharing_relation = probe.value("cpus_relation", std::string());
    }
  } else if (const auto& probe = written.at("false_sharing_probe"); !probe.is_null()) {
    for (const auto& info : lockstep::bench::probes::all_access_patterns)
      if (info.older_files_figure) probes.false_sharing.push_back(false_sharing_of(probe, std::string(info.name)));
  }
  probes.false_sharing_unavailable = written.value("false_sharing_probe_unavailable", std::string());
  if (const auto& probe = written.at("migration_probe"); !probe.is_null()) {
    bench::migration_probe migration;
    migration.cpus = probe.at("cpus").get<std::string>();
    migration.bytes = probe.at("bytes").get<std::size_t>();
    migration.move.count = probe.at("moves").get<std::size_t>();
    migration.move.p50 = probe.at("move_p50_ns").get<double>();
    migration.refill.p50 = probe.at("refill_p50_ns").get<double>();
    probes.migration = migration;
  }
  return probes;
}

// Compares `text` with the golden file tests/fixtures/run/<name>; with
// LOCKSTEP_UPDATE_GOLDEN=1 in the environment it writes the file instead.
void expect_golden(const std::string& name, const std::string& text) {
  const std::string path = std::string(LOCKSTEP_SOURCE_DIR) + "/tests/fixtures/run/" + name;
  if (const char* update = std::getenv("LOCKSTEP_UPDATE_GOLDEN"); update && std::string(update) == "1") {
    std::ofstream(path) << text;
    return;
  }
  std::ifstream in(path);
  ASSERT_TRUE(in) << path << " is missing: run with LOCKSTEP_UPDATE_GOLDEN=1 to write it";
  const std::string golden((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, golden) << "the output differs from " << path
                          << " (LOCKSTEP_UPDATE_GOLDEN=1 rewrites it where the change is meant)";
}

// What the run prints and derives from the fixture's book, held to golden
// files: a change of structure must not change a character of it; a change
// of behaviour rewrites the golden files in the same commit.
TEST(RunFixture, TheSummaryAnswerAndTheirJsonMatchTheGoldenFiles) {
  bench::run_book book = book_of(fixture());
  bench::run_result result;
  result.answer = answer_of(book, probes_of(fixture()), /*cpus=*/2, "quick-pairs.json");
  result.book = std::move(book);
  expect_golden("quick-pairs.summary.txt", bench::render_summary(result, "quick-pairs.json", /*verbose=*/false));
  expect_golden("quick-pairs.summary-verbose.txt", bench::render_summary(result, "quick-pairs.json", /*verbose=*/true));
  // The golden file keeps the name the key had when it was written.
  expect_golden("quick-pairs.headline.json", bench::answer_json(result.answer).dump(2) + "\n");
}

// Real run files from two kinds of machine: the AMD guest's quick Debug run
// and a trimmed copy of an Intel guest's default Release run
// (reports/tests/fixtures/trim_real_run.py says what was kept).
const nlohmann::json& real_file(const std::string& relative) {
  static std::map<std::string, nlohmann::json> files;
  auto found = files.find(relative);
  if (found == files.end()) {
    std::ifstream in(std::string(LOCKSTEP_SOURCE_DIR) + "/" + relative);
    found = files.emplace(relative, nlohmann::json::parse(in)).first;
  }
  return found->second;
}

// The answer never recommends a combination that its own pair with the
// runner-up calls slower (the runner-up's step over the choice's, its
// whole interval below 1), and a pair that cannot tell them apart (within
// noise or unsure) is printed as a tie naming both.
TEST(RunFixture, TheAnswerRecommendsWhatItsPairsSupportAndNamesTiesAsTies) {
  for (const std::string relative :
       {"tests/fixtures/run/quick-pairs.json", "reports/tests/fixtures/xeon_default_run_trimmed.json"}) {
    SCOPED_TRACE(relative);
    bench::run_book book = book_of(real_file(relative));
    const bench::run_answer answer = answer_of(book, {}, 2, "x.json");
    std::size_t paired = 0;
    for (const bench::answer_choice& choice : answer.choices) {
      SCOPED_TRACE(choice.entry);
      if (!choice.runner_up) continue;
      ++paired;
      EXPECT_FALSE(choice.runner_up->estimate.high < 1.0) << "the runner-up was faster side by side";
      const bool clear = choice.runner_up->verdict == bench::ratio_verdict::penalty;
      EXPECT_EQ(choice.tied, !clear);
      const std::string first = choice.sync + " + " + choice.layout;
      const std::string both = first + " or " + choice.runner_up->sync + " + " + choice.runner_up->layout + " (tied)";
      const auto line = std::find_if(answer.lines.begin(), answer.lines.end(), [&](const std::string& l) {
        return l.find(fmt::format("threads:{} pin:{}", choice.threads, lockstep::platform::to_string(choice.pin))) !=
                   std::string::npos &&
               l.find(first) != std::string::npos;
      });
      ASSERT_NE(line, answer.lines.end()) << bench::answer_text(answer);
      EXPECT_EQ(line->find(both) != std::string::npos, choice.tied) << *line;
    }
    EXPECT_GT(paired, 0u);
  }
}

// No line of the answer is cut: the result file's lines are whole, and the
// terminal's text wraps them without losing a character.
TEST(RunFixture, NoAnswerLineIsCut) {
  for (const std::string relative :
       {"tests/fixtures/run/quick-pairs.json", "reports/tests/fixtures/xeon_default_run_trimmed.json"}) {
    SCOPED_TRACE(relative);
    bench::run_book book = book_of(real_file(relative));
    const bench::run_answer answer = answer_of(book, probes_of(real_file(relative)), 2, "x.json");
    std::string joined_lines;
    for (const auto& line : answer.lines) {
      EXPECT_FALSE(line.ends_with("...")) << line;
      joined_lines += line;
    }
    std::string text = bench::answer_text(answer);
    std::string rejoined;
    std::istringstream stream(text);
    for (std::string piece; std::getline(stream, piece);) {
      EXPECT_LE(piece.size(), 120u) << piece;
      rejoined += piece.substr(std::min(piece.find_first_not_of(' '), piece.size()));
    }
    std::string without_spaces;
    for (const char c : joined_lines) if (c != ' ') without_spaces += c;
    std::string rejoined_without_spaces;
    for (const char c : rejoined) if (c != ' ') rejoined_without_spaces += c;
    EXPECT_EQ(rejoined_without_spaces, without_spaces);
  }
}

}  // namespace
