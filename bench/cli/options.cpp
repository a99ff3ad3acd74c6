// lockstep's command-line grammar (options.hpp).
#include "bench/cli/options.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <sstream>
#include <utility>

#include "bench/results/result_file.hpp"
#include "kernels/model_choice.hpp"
#include "layouts/registry.hpp"
#include "platform/placement.hpp"
#include "sync/registry.hpp"

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

// The units a time takes, the largest first, and how many nanoseconds each is.
constexpr std::pair<const char*, std::int64_t> kTimeUnits[] = {
    {"s", 1'000'000'000}, {"ms", 1'000'000}, {"us", 1'000}, {"ns", 1}};
constexpr const char* kTimeUnitNames = "ns, us, ms or s";

// "1ms", "60s", "1500us", "0": `ns` in the largest unit that divides it.
std::string duration_text(std::int64_t ns) {
  if (ns == 0) return "0";
  for (const auto& [unit, ns_per_unit] : kTimeUnits)
    if (ns % ns_per_unit == 0) return fmt::format("{}{}", ns / ns_per_unit, unit);
  return fmt::format("{}ns", ns);
}

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
  for (const auto& [name, ns_per_unit] : kTimeUnits)
    if (unit == name) scale = static_cast<double>(ns_per_unit);
  if (scale == 0 && unit.empty())
    throw usage_error(fmt::format("{}: '{}' needs a unit ({}; example: 1ms)", option, text, kTimeUnitNames));
  if (scale == 0)
    throw usage_error(fmt::format("{}: '{}': unknown unit '{}' ({})", option, text, unit, kTimeUnitNames));
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
    throw usage_error(fmt::format("{}: '{}' is out of range ({} to {})", option, text, duration_text(min_ns),
                                  duration_text(max_ns)));
  return static_cast<std::int64_t>(std::llround(ns));
}

namespace {

// "64B", "4KiB", "16GiB": the largest binary unit that divides `bytes`.
std::string size_text(std::uint64_t bytes) {
  constexpr std::pair<std::uint64_t, const char*> units[] = {
      {1ULL << 30, "GiB"}, {1ULL << 20, "MiB"}, {1ULL << 10, "KiB"}};
  for (const auto& [scale, unit] : units)
    if (bytes != 0 && bytes % scale == 0) return fmt::format("{}{}", bytes / scale, unit);
  return fmt::format("{}B", bytes);
}

// A decimal number as the sizes and percentages write it: digits, at most one
// point, at least one digit; no sign, no exponent. Where it ends in `text`.
std::size_t decimal_end(const std::string& text) {
  std::size_t end = 0;
  bool point = false;
  bool digit = false;
  for (; end < text.size(); ++end) {
    const char c = text[end];
    if (c >= '0' && c <= '9') {
      digit = true;
    } else if (c == '.' && !point) {
      point = true;
    } else {
      break;
    }
  }
  return digit ? end : 0;
}

// The value of a number decimal_end accepted (strtod: no exception; a number
// too large for a double is infinite, and out of every range).
double decimal_value(const std::string& number) { return std::strtod(number.c_str(), nullptr); }

std::string lowercase(std::string text) {
  for (char& c : text) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

std::string trimmed(const std::string& text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t") - first + 1);
}

}  // namespace

std::uint64_t parse_size_bytes(const std::string& text, const std::string& option, std::uint64_t min_bytes,
                               std::uint64_t max_bytes) {
  const std::size_t number_end = decimal_end(text);
  if (number_end == 0)
    throw usage_error(fmt::format("{}: '{}' is not a size (examples: 256KiB, 4MiB, 65536 for bytes)", option, text));
  const std::string unit = text.substr(number_end);
  double scale = 0;
  if (unit.empty() || unit == "B")
    scale = 1;
  else if (unit == "KiB")
    scale = 1024.0;
  else if (unit == "MiB")
    scale = 1024.0 * 1024.0;
  else if (unit == "GiB")
    scale = 1024.0 * 1024.0 * 1024.0;
  else if (const std::string lower = lowercase(unit);
           lower == "k" || lower == "kb" || lower == "m" || lower == "mb" || lower == "g" || lower == "gb")
    throw usage_error(fmt::format("{}: '{}': {} is read as 1000 or as 1024 by different tools; write {}{}iB for "
                                  "powers of 1024 (or the number of bytes)",
                                  option, text, unit, text.substr(0, number_end),
                                  static_cast<char>(std::toupper(static_cast<unsigned char>(lower[0])))));
  else
    throw usage_error(fmt::format("{}: '{}': unknown unit '{}' (B, KiB, MiB or GiB, or none for bytes)", option,
                                  text, unit));
  const double bytes = decimal_value(text.substr(0, number_end)) * scale;
  if (bytes != std::floor(bytes))
    throw usage_error(fmt::format("{}: '{}' is not a whole number of bytes", option, text));
  if (bytes < static_cast<double>(min_bytes) || bytes > static_cast<double>(max_bytes))
    throw usage_error(fmt::format("{}: '{}' is out of range ({} to {})", option, text, size_text(min_bytes),
                                  size_text(max_bytes)));
  return static_cast<std::uint64_t>(bytes);
}

std::vector<std::uint64_t> parse_size_list(const std::string& text, const std::string& option,
                                           std::uint64_t min_bytes, std::uint64_t max_bytes) {
  std::vector<std::uint64_t> sizes;
  for (const std::string& item : items_of(text, option)) {
    const std::uint64_t size = parse_size_bytes(item, option, min_bytes, max_bytes);
    if (std::find(sizes.begin(), sizes.end(), size) == sizes.end()) sizes.push_back(size);
  }
  return sizes;
}

double parse_percent(const std::string& text, const std::string& option) {
  std::string number = trimmed(text);
  if (!number.empty() && number.back() == '%') number = trimmed(number.substr(0, number.size() - 1));
  if (number.empty() || decimal_end(number) != number.size())
    throw usage_error(fmt::format("{}: '{}' is not a percentage (examples: 5, 5%, 0.5%)", option, text));
  const double percent = decimal_value(number);
  if (percent > 100.0) throw usage_error(fmt::format("{}: '{}' is out of range (0 to 100 percent)", option, text));
  return percent;
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

const std::string& check_name(const std::string& name, const std::vector<std::string>& valid,
                              const std::string& unknown) {
  if (std::find(valid.begin(), valid.end(), name) != valid.end()) return name;
  if (const auto nearest = nearest_name(name, valid))
    throw usage_error(fmt::format("{} '{}' (did you mean {}?)", unknown, name, *nearest));
  throw usage_error(fmt::format("{} '{}' (valid: {})", unknown, name, joined(valid)));
}

std::vector<std::string> select_names(const std::optional<std::string>& wanted, const std::vector<std::string>& valid,
                                      const std::string& option) {
  if (!wanted) return valid;
  std::vector<std::string> chosen;
  for (const std::string& name : items_of(*wanted, option)) {
    check_name(name, valid, option + ": unknown value");
    if (std::find(chosen.begin(), chosen.end(), name) == chosen.end()) chosen.push_back(name);
  }
  return chosen;
}

std::vector<std::string> sync_names() {
  std::vector<std::string> names;
  for (const auto& info : sync::all_primitive_info) names.emplace_back(info.name);
  return names;
}

std::vector<std::string> layout_names() {
  std::vector<std::string> names;
  for (const auto& info : layouts::all_layout_info) names.emplace_back(info.name);
  return names;
}

std::vector<std::string> placement_names() {
  std::vector<std::string> names;
  for (const auto& description : platform::placements()) names.emplace_back(description.name);
  return names;
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

CLI::Option* add_noise_option(CLI::App& command, double& percent, const std::string& what) {
  // The transform reads the words (parse_percent throws usage_error, one
  // line) and hands CLI11 the bare number it stores in `percent`.
  const CLI::Validator as_percent(
      [](std::string& text) {
        text = fmt::format("{}", parse_percent(text, "--noise"));
        return std::string();
      },
      "");
  return command
      .add_option("--noise", percent,
                  fmt::format("The noise band in percent, 0 to 100, the sign optional (5 or 5%; default {:g}): {}",
                              percent, what))
      ->transform(as_percent)
      ->option_text("PCT");
}

CLI::Option* add_repetitions_option(CLI::App& command, int& repetitions, int max, const std::string& one,
                                    const std::string& old_name) {
  std::string names = "--repetitions";
  std::string description =
      fmt::format("How many times the whole measurement is repeated, 1 to {} (default {}); one repetition: {}", max,
                  repetitions, one);
  if (!old_name.empty()) {
    names += "," + old_name;
    description += fmt::format(" ({} is the old name, still accepted)", old_name);
  }
  return command.add_option(names, repetitions, description)->check(CLI::Range(1, max))->option_text("N");
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  // distance[i][j]: a's first i characters against b's first j.
  std::vector<std::vector<std::size_t>> distance(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) distance[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) distance[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitution = a[i - 1] == b[j - 1] ? 0 : 1;
      distance[i][j] = std::min({distance[i - 1][j] + 1, distance[i][j - 1] + 1, distance[i - 1][j - 1] + substitution});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        distance[i][j] = std::min(distance[i][j], distance[i - 2][j - 2] + 1);
    }
  }
  return distance[a.size()][b.size()];
}

std::optional<std::string> nearest_name(const std::string& word, const std::vector<std::string>& candidates) {
  const std::size_t allowed = word.size() <= 4 ? 1 : word.size() <= 8 ? 2 : 3;
  std::optional<std::string> nearest;
  std::size_t nearest_distance = allowed + 1;
  for (const std::string& candidate : candidates) {
    const std::size_t distance = edit_distance(word, candidate);
    if (distance < nearest_distance) {
      nearest = candidate;
      nearest_distance = distance;
    }
  }
  if (nearest || word.size() < 3) return nearest;
  std::vector<std::string> begun;
  for (const std::string& candidate : candidates)
    if (candidate.rfind(word, 0) == 0 && std::find(begun.begin(), begun.end(), candidate) == begun.end())
      begun.push_back(candidate);
  if (begun.size() == 1) return begun.front();
  return std::nullopt;
}

namespace {

std::vector<std::string> command_names(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; }))
    names.push_back(command->get_name());
  return names;
}

// The name `command` gives the option another command of `root` takes as
// `bare` (run's --repetitions for falseshare's old --repeats), when it has one.
std::optional<std::string> sibling_name(const CLI::App& root, const CLI::App& command, const std::string& bare) {
  for (const CLI::App* sibling : root.get_subcommands([](const CLI::App*) { return true; })) {
    for (const CLI::Option* option : sibling->get_options()) {
      const auto& long_names = option->get_lnames();
      if (std::find(long_names.begin(), long_names.end(), bare) == long_names.end()) continue;
      for (const CLI::Option* own : command.get_options())
        if (!own->get_lnames().empty() && own->get_lnames().front() == long_names.front())
          return "--" + long_names.front();
    }
  }
  return std::nullopt;
}

// "--quik", "--quik=1", "-quick": an option no one took, named beside the
// nearest option of `command` (its first long name, an old alias's too), or
// the option of `command` another command takes under this name.
std::string unknown_option_message(const CLI::App& root, const CLI::App& command, const std::string& word,
                                   const std::string& help) {
  const std::string option = word.substr(0, word.find('='));
  std::vector<std::string> spellings;  // without the dashes, as typed after them
  std::vector<std::string> primary;    // the name the help leads with, for each spelling
  for (const CLI::Option* candidate : command.get_options()) {
    const auto& long_names = candidate->get_lnames();
    if (long_names.empty()) continue;
    for (const std::string& name : long_names) {
      spellings.push_back(name);
      primary.push_back("--" + long_names.front());
    }
  }
  const std::string bare = option.substr(std::min(option.find_first_not_of('-'), option.size()));
  if (const auto nearest = nearest_name(bare, spellings)) {
    const auto at = std::find(spellings.begin(), spellings.end(), *nearest) - spellings.begin();
    return fmt::format("unknown option {}; did you mean {}?", option, primary[static_cast<std::size_t>(at)]);
  }
  if (const auto name = sibling_name(root, command, bare))
    return fmt::format("unknown option {}; did you mean {}?", option, *name);
  return fmt::format("unknown option {} (`{} --help` lists the options)", option, help);
}

}  // namespace

std::string unknown_command_message(const CLI::App& app, const std::string& word) {
  if (const auto nearest = nearest_name(word, command_names(app)))
    return fmt::format("unknown command '{}'; did you mean '{}'?", word, *nearest);
  return fmt::format("unknown command '{}'; `{} --help` lists the commands", word, app.get_name());
}

std::string unknown_word_message(const CLI::App& app) {
  // Before the command: an option of no one's, or a command that is not one.
  for (const std::string& word : app.remaining()) {
    if (word.rfind('-', 0) == 0) return unknown_option_message(app, app, word, app.get_name());
    return unknown_command_message(app, word);
  }
  const std::vector<const CLI::App*> parsed = app.get_subcommands([](const CLI::App* command) {
    return command->parsed();
  });
  if (parsed.empty()) return fmt::format("no command given; `{} --help` lists the commands", app.get_name());
  for (const CLI::App* command : parsed) {
    // compare and report hand every word to their Python tool (reports.cpp).
    if (command->get_allow_extras() || command->get_prefix_command()) continue;
    const std::string help = app.get_name() + " " + command->get_name();
    for (const std::string& word : command->remaining()) {
      if (word.rfind('-', 0) == 0) return unknown_option_message(app, *command, word, help);
      return fmt::format("unexpected argument '{}' (`{} --help` lists the options)", word, help);
    }
  }
  return "";
}

CLI::Option* add_masses_option(CLI::App& command, std::optional<std::size_t>& masses, const std::string& member) {
  const std::string description =
      member.empty()
          ? std::string("Integrate the uniform S-mass chain (eq. (1), 2S equations) instead of the paper's two masses")
          : fmt::format("Integrate an S-mass chain (eq. (1), 2S equations) whatever the {0}s (default: the paper's "
                        "two masses up to {1} {0}s, else a chain of one equation per {0})",
                        member, kernels::kPaperThreadsMax);
  return command.add_option("--masses", masses, description)
      ->check(CLI::Range(std::size_t{1}, kMassesMax))
      ->option_text("S");
}

}  // namespace lockstep::cli
