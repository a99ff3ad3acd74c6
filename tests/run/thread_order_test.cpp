// Every table of the summary and every list of the answer in numeric thread
// order, on a hand-made run book of 2, 4, 8 and 16 threads recorded out of
// order: "16" sorted as text comes before "2" (the bare primitives' table did
// so). No timing is measured or asserted.
#include <gtest/gtest.h>

#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "bench/run/answer.hpp"
#include "bench/run/paired_blocks.hpp"
#include "bench/run/run_book.hpp"
#include "bench/run/run_result.hpp"
#include "bench/run/summary.hpp"
#include "platform/placement.hpp"

namespace {

namespace bench = lockstep::bench;
namespace platform = lockstep::platform;

constexpr unsigned kThreads[] = {16, 2, 8, 4};  // recorded in this order

void add(bench::run_book& book, const bench::entry_spec& spec, double time, bool oversubscribed) {
  bench::captured_entry entry;
  entry.spec = spec;
  entry.name = spec.name();
  const std::string counter(spec.time_counter());
  for (int repetition = 0; repetition < 3; ++repetition)
    entry.repetitions.push_back({{counter, time}, {"oversubscribed", oversubscribed ? 1.0 : 0.0}, {"vs_c2c", 1.0}});
  book.record(std::move(entry));
}

// Two primitives on two layouts (one whose writers share lines, one that
// isolates them) at every thread count, their bare episodes too, and pairs
// measured for every comparison the book plans.
bench::run_result four_thread_counts() {
  bench::run_result result;
  bench::run_book& book = result.book;
  for (const unsigned threads : kThreads) {
    const lockstep::kernels::model_choice model{threads > 4 ? threads / 2 : 0};
    const bool over = threads > 2;
    for (const char* sync : {"mailbox", "std_barrier"}) {
      const double base = (sync[0] == 'm' ? 1000.0 : 3000.0) * threads;
      add(book, bench::entry_spec::parallel_step(sync, "packed", platform::placement::compact, threads, model),
          base * 1.2, over);
      add(book, bench::entry_spec::parallel_step(sync, "padded64", platform::placement::compact, threads, model),
          base, over);
      add(book, bench::entry_spec::barrier_episode(sync, platform::placement::compact, threads), base / 4.0, over);
    }
    // A pure spinner that collapses once the threads outnumber the CPUs.
    if (over)
      add(book, bench::entry_spec::parallel_step("ck_centralized", "packed", platform::placement::compact, threads, model),
          300'000.0 * threads, over);
  }
  book.collapsed = bench::find_collapsed(book);
  for (const bench::comparison& what : bench::plan_comparisons(book)) {
    bench::paired_result pair;
    pair.what = what;
    pair.ratios = {1.2, 1.21, 1.19, 1.2};
    pair.estimate = bench::bootstrap_median(pair.ratios);
    pair.verdict = bench::verdict_of(pair.estimate, book.noise);
    book.pairs.push_back(pair);
  }
  result.answer = bench::make_answer(book, bench::choose_combinations(book), {{}, 2, "x.json", nullptr, nullptr});
  return result;
}

// The thread counts named on the lines of one section of `text` (from the
// line that starts with `heading` to the next blank line), in order.
std::vector<unsigned> threads_in(const std::string& text, const std::string& heading) {
  const std::size_t start = text.find(heading);
  EXPECT_NE(start, std::string::npos) << heading << " missing in:\n" << text;
  if (start == std::string::npos) return {};
  const std::size_t end = text.find("\n\n", start);
  const std::string section = text.substr(start, end == std::string::npos ? std::string::npos : end - start);
  std::vector<unsigned> found;
  const std::regex threads(R"(threads:(\d+))");
  for (auto match = std::sregex_iterator(section.begin(), section.end(), threads); match != std::sregex_iterator();
       ++match)
    found.push_back(static_cast<unsigned>(std::stoul((*match)[1])));
  return found;
}

// The thread counts on the lines of that section that start with `prefix`.
std::vector<unsigned> threads_on_lines(const std::string& text, const std::string& heading, const std::string& prefix) {
  const std::size_t start = text.find(heading);
  if (start == std::string::npos) return {};
  std::istringstream lines(text.substr(start, text.find("\n\n", start) - start));
  std::vector<unsigned> found;
  for (std::string line; std::getline(lines, line);)
    if (line.rfind(prefix, 0) == 0)
      for (const unsigned threads : threads_in(line, prefix)) found.push_back(threads);
  return found;
}

void expect_ascending(const std::vector<unsigned>& threads, const std::string& what) {
  EXPECT_FALSE(threads.empty()) << what;
  for (std::size_t index = 1; index < threads.size(); ++index)
    EXPECT_LE(threads[index - 1], threads[index]) << what << ": " << ::testing::PrintToString(threads);
}

TEST(ThreadOrder, EveryTableOfTheSummaryIsInNumericThreadOrder) {
  const bench::run_result result = four_thread_counts();
  const std::string verbose = bench::render_summary(result, "x.json", /*verbose=*/true);
  expect_ascending(threads_in(verbose, "Bare primitives, median time per episode:"), "the bare primitives");
  for (const char* group : {"  RK4 step ", "  bare episode "})
    EXPECT_EQ(threads_on_lines(verbose, "Each primitive against the best other", group),
              (std::vector<unsigned>{2, 4, 8, 16}))
        << group << "\n" << verbose;
  EXPECT_EQ(threads_on_lines(verbose, "Ran oversubscribed", "Ran oversubscribed"), (std::vector<unsigned>{4, 8, 16}))
      << verbose;
  EXPECT_EQ(threads_in(verbose, "Collapsed ("), (std::vector<unsigned>{4, 8, 16})) << verbose;
  // False sharing: per primitive, its thread counts in order.
  for (const char* sync : {"sync:mailbox ", "sync:std_barrier "}) {
    std::vector<unsigned> threads;
    const std::string section = verbose.substr(verbose.find("False-sharing penalty per primitive"));
    std::istringstream lines(section.substr(0, section.find("\n\n")));
    for (std::string line; std::getline(lines, line);)
      if (line.find(sync) != std::string::npos) {
        const std::vector<unsigned> here = threads_in(line, sync);
        threads.insert(threads.end(), here.begin(), here.end());
      }
    EXPECT_EQ(threads, (std::vector<unsigned>{2, 4, 8, 16})) << sync << "\n" << verbose;
  }
  const std::string short_summary = bench::render_summary(result, "x.json", /*verbose=*/false);
  EXPECT_EQ(threads_in(short_summary, "Fastest 3 per thread count"), (std::vector<unsigned>{2, 4, 8, 16}))
      << short_summary;
}

TEST(ThreadOrder, TheAnswersChoicesAreInNumericThreadOrder) {
  const bench::run_result result = four_thread_counts();
  std::vector<unsigned> threads;
  for (const bench::answer_choice& choice : result.answer.choices) threads.push_back(choice.threads);
  EXPECT_EQ(threads, (std::vector<unsigned>{2, 4, 8, 16}));
  const std::string text = bench::answer_text(result.answer);
  EXPECT_EQ(threads_in(text, "Collapsed when threads outnumber CPUs"), (std::vector<unsigned>{4, 8, 16})) << text;
  std::vector<unsigned> ranked;
  for (const bench::ranked_group& group : bench::rank_groups(result.book, bench::entry_kind::barrier))
    ranked.push_back(group.threads);
  EXPECT_EQ(ranked, (std::vector<unsigned>{2, 4, 8, 16}));
}

}  // namespace
