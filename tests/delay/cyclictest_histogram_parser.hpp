#pragma once
// A small reader of cyclictest's -h histogram text, written from its
// documentation (man cyclictest: -h/--histogram, --histfile) and its output,
// not from lockstep's writer, so that a test can check lockstep's file the
// way an engineer's script reads cyclictest's:
//   lines starting with '#' are comments, except the summaries
//     "# Total:", "# Min Latencies:", "# Avg Latencies:", "# Max Latencies:",
//     "# Histogram Overflows:"   one number per thread after the colon,
//     "# Thread N:"              the overflow cycle numbers, then optionally
//                                "# K others";
//   every other non-empty line is "bucket count count ...": the bucket in
//   microseconds, then one count per thread (separated by blanks or tabs).
#include <cstdint>
#include <istream>
#include <sstream>
#include <string>
#include <vector>

namespace lockstep::testing {

struct cyclictest_histogram {
  std::vector<std::int64_t> buckets;                // bucket values in order
  std::vector<std::vector<std::uint64_t>> counts;   // [thread][bucket index]
  std::vector<std::uint64_t> total, min, avg, max, overflows;
  std::vector<std::vector<std::uint64_t>> overflow_cycles;  // [thread]
  std::vector<std::uint64_t> others;                // [thread]: cycles not listed
  std::string error;                                // empty: read cleanly
};

inline cyclictest_histogram parse_cyclictest_histogram(std::istream& in) {
  cyclictest_histogram result;
  const auto numbers_after = [](const std::string& text) {
    std::vector<std::uint64_t> values;
    std::istringstream fields(text);
    std::uint64_t value = 0;
    while (fields >> value) values.push_back(value);
    return values;
  };
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] == '#') {
      const auto summary = [&](const char* label, std::vector<std::uint64_t>& into) {
        const std::string prefix = label;
        if (line.rfind(prefix, 0) != 0) return false;
        into = numbers_after(line.substr(prefix.size()));
        return true;
      };
      if (summary("# Total:", result.total) || summary("# Min Latencies:", result.min) ||
          summary("# Avg Latencies:", result.avg) || summary("# Max Latencies:", result.max) ||
          summary("# Histogram Overflows:", result.overflows))
        continue;
      if (line.rfind("# Thread ", 0) == 0) {
        const auto colon = line.find(':');
        if (colon == std::string::npos) {
          result.error = "a thread line without a colon: " + line;
          return result;
        }
        std::string rest = line.substr(colon + 1);
        std::uint64_t others = 0;
        if (const auto hash = rest.find('#'); hash != std::string::npos) {
          std::istringstream tail(rest.substr(hash + 1));
          std::string word;
          tail >> others >> word;
          if (word != "others") {
            result.error = "a thread line with '#' but no 'others': " + line;
            return result;
          }
          rest = rest.substr(0, hash);
        }
        result.overflow_cycles.push_back(numbers_after(rest));
        result.others.push_back(others);
      }
      continue;  // any other comment
    }
    std::istringstream fields(line);
    std::int64_t bucket = 0;
    if (!(fields >> bucket)) {
      result.error = "not a bucket line: " + line;
      return result;
    }
    std::vector<std::uint64_t> row;
    std::uint64_t count = 0;
    while (fields >> count) row.push_back(count);
    if (result.counts.empty()) result.counts.resize(row.size());
    if (row.empty() || row.size() != result.counts.size()) {
      result.error = "a bucket line with another number of threads: " + line;
      return result;
    }
    result.buckets.push_back(bucket);
    for (std::size_t thread = 0; thread < row.size(); ++thread) result.counts[thread].push_back(row[thread]);
  }
  return result;
}

}  // namespace lockstep::testing
