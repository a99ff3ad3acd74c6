// lockstep's command-line grammar (options.hpp).
#include "bench/cli/options.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "bench/harness/result_file.hpp"

namespace lockstep::cli {

namespace {

// The comma list's items; an empty item (",", "a,,b", "a,") is refused.
std::vector<std::string> items_of(const std::string& text, const std::string& option) {
  if (text.empty()) throw usage_error(fmt::format("{}: the list is empty", option));
  std::vector<std::string> items;
  std::stringstream pieces(text);
  std::string piece;
  while (std::getline(pieces, piece, ',')) {
    if (piece.empty()) throw usage_error(fmt::format("{}: '{}' has an empty item", option, text));
    items.push_back(piece);
  }
  if (items.empty() || text.back() == ',')
    throw usage_error(fmt::format("{}: '{}' has an empty item", option, text));
  return items;
}

long long whole_number(const std::string& text, const std::string& option) {
  if (text.empty() || text.size() > 18 || text.find_first_not_of("0123456789") != std::string::npos)
    throw usage_error(fmt::format("{}: '{}' is not a whole number", option, text));
  return std::stoll(text);
}

}  // namespace

namespace {

// The time `text` names, in nanoseconds (not rounded).
double duration_in_ns(const std::string& text, const std::string& option) {
  std::size_t digits_end = 0;
  double value = 0;
  try {
    value = std::stod(text, &digits_end);
  } catch (const std::exception&) {
    throw usage_error(fmt::format("{}: '{}' is not a time (examples: 1ms, 250us, 10s)", option, text));
  }
  const std::string unit = text.substr(digits_end);
  double scale = 0;
  if (unit == "ns")
    scale = 1;
  else if (unit == "us")
    scale = 1e3;
  else if (unit == "ms")
    scale = 1e6;
  else if (unit == "s")
    scale = 1e9;
  else
    throw usage_error(fmt::format("{}: '{}' needs a unit: ns, us, ms or s (example: 1ms)", option, text));
  const double ns = value * scale;
  if (!std::isfinite(ns)) throw usage_error(fmt::format("{}: '{}' is not a finite time", option, text));
  return ns;
}

}  // namespace

double parse_duration_seconds(const std::string& text, const std::string& option) {
  return duration_in_ns(text, option) / 1e9;
}

std::int64_t parse_duration_ns(const std::string& text, const std::string& option, std::int64_t min_ns,
                               std::int64_t max_ns) {
  const double ns = duration_in_ns(text, option);
  if (!std::isfinite(ns) || ns < static_cast<double>(min_ns) || ns > static_cast<double>(max_ns))
    throw usage_error(fmt::format("{}: '{}' is out of range ({}ns to {}ns)", option, text, min_ns, max_ns));
  return static_cast<std::int64_t>(std::llround(ns));
}

std::vector<long long> parse_number_list(const std::string& text, const std::string& option, long long min,
                                         long long max) {
  std::vector<long long> numbers;
  for (const std::string& item : items_of(text, option)) {
    const long long value = whole_number(item, option);
    if (value < min || value > max)
      throw usage_error(fmt::format("{}: {} is out of range ({} to {})", option, value, min, max));
    if (std::find(numbers.begin(), numbers.end(), value) == numbers.end()) numbers.push_back(value);
  }
  return numbers;
}

std::string joined(const std::vector<std::string>& names) {
  std::string list;
  for (const auto& name : names) list += (list.empty() ? "" : ", ") + name;
  return list;
}

std::vector<std::string> select_names(const std::optional<std::string>& wanted, const std::vector<std::string>& valid,
                                      const std::string& option) {
  if (!wanted) return valid;
  std::vector<std::string> chosen;
  for (const std::string& name : items_of(*wanted, option)) {
    if (std::find(valid.begin(), valid.end(), name) == valid.end())
      throw usage_error(fmt::format("{}: unknown value '{}' (valid: {})", option, name, joined(valid)));
    if (std::find(chosen.begin(), chosen.end(), name) == chosen.end()) chosen.push_back(name);
  }
  return chosen;
}

void check_out(const std::string& path) {
  if (path.empty()) return;
  try {
    bench::check_result_path(path);
  } catch (const bench::result_path_error& error) {
    throw usage_error(std::string("--out: ") + error.what());
  }
}

std::vector<int> parse_cpu_list(const std::string& text, const std::string& option) {
  std::vector<int> cpus;
  for (const std::string& piece : items_of(text, option)) {
    const auto dash = piece.find('-');
    const auto number = [&](const std::string& digits) {
      if (digits.empty() || digits.size() > 6 || digits.find_first_not_of("0123456789") != std::string::npos)
        throw usage_error(fmt::format("{}: '{}' is not a CPU number or range (example: 0,2,4-7)", option, piece));
      return std::stoi(digits);
    };
    if (dash == std::string::npos) {
      cpus.push_back(number(piece));
    } else {
      const int from = number(piece.substr(0, dash));
      const int to = number(piece.substr(dash + 1));
      if (to < from) throw usage_error(fmt::format("{}: range '{}' runs backwards", option, piece));
      for (int cpu = from; cpu <= to; ++cpu) cpus.push_back(cpu);
    }
  }
  std::sort(cpus.begin(), cpus.end());
  cpus.erase(std::unique(cpus.begin(), cpus.end()), cpus.end());
  return cpus;
}

std::vector<int> usable_cpus(const platform::topology& machine, bool include_smt_siblings) {
  std::vector<int> cpus;
  std::vector<unsigned> cores_seen;
  for (unsigned cpu : machine.affinity()) {
    const unsigned core = machine.pu(cpu).core;
    if (!include_smt_siblings && std::find(cores_seen.begin(), cores_seen.end(), core) != cores_seen.end()) continue;
    cores_seen.push_back(core);
    cpus.push_back(static_cast<int>(cpu));
  }
  return cpus;
}

std::vector<int> restrict_to(const std::vector<int>& usable, const std::vector<int>& requested,
                             const std::string& option) {
  for (int cpu : requested)
    if (std::find(usable.begin(), usable.end(), cpu) == usable.end())
      throw usage_error(fmt::format("{}: CPU {} is not usable here (offline, outside this process's affinity, or an "
                                    "SMT sibling skipped without --smt)",
                                    option, cpu));
  return requested;
}

CLI::Option* add_out_option(CLI::App& command, std::string& path, const std::string& what) {
  return command.add_option("--out", path,
                            "Write " + what + " to FILE (atomically; its directory must exist and be writable)")
      ->option_text("FILE");
}

CLI::Option* add_masses_option(CLI::App& command, std::optional<std::size_t>& masses) {
  return command
      .add_option("--masses", masses,
                  "Integrate an S-mass chain (eq. (1), 2S equations) whatever the threads (default: the paper's "
                  "two masses up to 4 threads, else a chain of one equation per thread)")
      ->check(CLI::Range(std::size_t{1}, kMassesMax))
      ->option_text("S");
}

}  // namespace lockstep::cli
