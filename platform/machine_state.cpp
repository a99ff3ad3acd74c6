// The machine's state, read under a root, and the bias line (machine_state.hpp).
#include "platform/machine_state.hpp"

#include <sched.h>

#include <fmt/core.h>

#include <algorithm>
#include <charconv>
#include <cstdlib>
#include <fstream>
#include <mutex>
#include <sstream>
#include <system_error>

#include "platform/cpu_list.hpp"

namespace lockstep::platform {

namespace {

namespace fs = std::filesystem;

const fs::path kCpuDirectory = "sys/devices/system/cpu";

// The first line of a file, without its newline; nullopt when it cannot be
// read. An empty file is an empty line (sysfs prints "\n" for an empty CPU
// list; a fixture may hold nothing at all).
std::optional<std::string> first_line(const fs::path& path) {
  std::ifstream file(path);
  if (!file.is_open()) return std::nullopt;
  std::string line;
  std::getline(file, line);
  if (file.bad()) return std::nullopt;
  while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
  return line;
}

std::string word_or_unavailable(const fs::path& path) {
  const auto line = first_line(path);
  if (!line || line->empty()) return kUnavailable;
  return *line;
}

std::optional<std::uint64_t> number_in(const fs::path& path) {
  const auto line = first_line(path);
  if (!line) return std::nullopt;
  std::uint64_t value = 0;
  const auto [end, error] = std::from_chars(line->data(), line->data() + line->size(), value);
  if (error != std::errc() || end != line->data() + line->size()) return std::nullopt;
  return value;
}

std::optional<std::vector<unsigned>> cpu_list_in(const fs::path& path) {
  const auto line = first_line(path);
  if (!line) return std::nullopt;
  return parse_cpu_list(*line);
}

// "always [madvise] never" -> "madvise".
std::string bracketed_choice(const fs::path& path) {
  const auto line = first_line(path);
  if (!line) return kUnavailable;
  const std::size_t open = line->find('[');
  const std::size_t close = line->find(']', open);
  if (open == std::string::npos || close == std::string::npos) return kUnavailable;
  return line->substr(open + 1, close - open - 1);
}

std::optional<unsigned> number_named(const std::string& name, std::string_view prefix) {
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return std::nullopt;
  unsigned value = 0;
  const char* first = name.data() + prefix.size();
  const auto [end, error] = std::from_chars(first, name.data() + name.size(), value);
  if (error != std::errc() || end != name.data() + name.size()) return std::nullopt;
  return value;
}

// Numbered entries of a directory ("cpu3" under sys/devices/system/cpu, "24"
// under proc/irq), sorted.
std::vector<unsigned> numbered_entries(const fs::path& directory, std::string_view prefix) {
  std::vector<unsigned> numbers;
  std::error_code error;
  for (fs::directory_iterator entry(directory, error), end; !error && entry != end; entry.increment(error)) {
    if (const auto number = number_named(entry->path().filename().string(), prefix)) numbers.push_back(*number);
  }
  std::sort(numbers.begin(), numbers.end());
  return numbers;
}

fs::path policy_of(const fs::path& root, unsigned cpu) {
  return root / kCpuDirectory / fmt::format("cpu{}", cpu) / "cpufreq";
}

cpu_frequency read_cpu_frequency(const fs::path& root, unsigned cpu) {
  const fs::path policy = policy_of(root, cpu);
  cpu_frequency reading;
  reading.cpu = cpu;
  reading.driver = word_or_unavailable(policy / "scaling_driver");
  reading.governor = word_or_unavailable(policy / "scaling_governor");
  reading.min_khz = number_in(policy / "cpuinfo_min_freq");
  reading.max_khz = number_in(policy / "cpuinfo_max_freq");
  reading.current_khz = number_in(policy / "scaling_cur_freq");
  return reading;
}

// intel_pstate's no_turbo first (it owns turbo where it drives), then the
// cpufreq core's global boost, then the per-policy boost files.
boost_state read_boost(const fs::path& root, const std::vector<unsigned>& cpus) {
  boost_state boost;
  if (const auto no_turbo = first_line(root / kCpuDirectory / "intel_pstate" / "no_turbo");
      no_turbo && (*no_turbo == "0" || *no_turbo == "1")) {
    boost.setting = *no_turbo == "0" ? boost_setting::on : boost_setting::off;
    boost.word = "turbo";
    boost.read_from = "intel_pstate/no_turbo = " + *no_turbo;
    boost.turn_off = "echo 1 > /sys/devices/system/cpu/intel_pstate/no_turbo";
    return boost;
  }
  if (const auto global = first_line(root / kCpuDirectory / "cpufreq" / "boost");
      global && (*global == "0" || *global == "1")) {
    boost.setting = *global == "1" ? boost_setting::on : boost_setting::off;
    boost.read_from = "cpufreq/boost = " + *global;
    boost.turn_off = "echo 0 > /sys/devices/system/cpu/cpufreq/boost";
    return boost;
  }
  bool any_read = false;
  bool any_on = false;
  for (unsigned cpu : cpus) {
    const auto value = first_line(policy_of(root, cpu) / "boost");
    if (!value || (*value != "0" && *value != "1")) continue;
    any_read = true;
    any_on = any_on || *value == "1";
  }
  if (any_read) {
    boost.setting = any_on ? boost_setting::on : boost_setting::off;
    boost.read_from = any_on ? "cpuN/cpufreq/boost = 1 on some CPU" : "cpuN/cpufreq/boost = 0 on every CPU";
    boost.turn_off = "echo 0 | tee /sys/devices/system/cpu/cpu*/cpufreq/boost";
  }
  return boost;
}

std::string read_pstate_status(const fs::path& root) {
  for (const char* driver : {"intel_pstate", "amd_pstate"}) {
    const auto status = first_line(root / kCpuDirectory / driver / "status");
    if (status && !status->empty()) return fmt::format("{} {}", driver, *status);
  }
  return kUnavailable;
}

std::optional<std::vector<irq_affinity>> read_irqs(const fs::path& root) {
  const fs::path directory = root / "proc" / "irq";
  std::error_code error;
  if (!fs::is_directory(directory, error)) return std::nullopt;
  std::vector<irq_affinity> irqs;
  for (unsigned irq : numbered_entries(directory, "")) {
    const fs::path line = directory / std::to_string(irq);
    irqs.push_back({irq, cpu_list_in(line / "smp_affinity_list"), cpu_list_in(line / "effective_affinity_list")});
  }
  return irqs;
}

bool meets(const std::vector<unsigned>& sorted_a, const std::vector<unsigned>& sorted_b) {
  auto a = sorted_a.begin();
  auto b = sorted_b.begin();
  while (a != sorted_a.end() && b != sorted_b.end()) {
    if (*a == *b) return true;
    if (*a < *b) ++a;
    else ++b;
  }
  return false;
}

std::vector<unsigned> sorted_unique(std::vector<unsigned> cpus) {
  std::sort(cpus.begin(), cpus.end());
  cpus.erase(std::unique(cpus.begin(), cpus.end()), cpus.end());
  return cpus;
}

// The CPUs this process may run on.
std::vector<unsigned> affinity_cpus() {
  std::vector<unsigned> cpus;
  cpu_set_t set;
  CPU_ZERO(&set);
  if (::sched_getaffinity(0, sizeof set, &set) != 0) return cpus;
  for (unsigned cpu = 0; cpu < CPU_SETSIZE; ++cpu)
    if (CPU_ISSET(cpu, &set)) cpus.push_back(cpu);
  return cpus;
}

}  // namespace

std::filesystem::path state_root() {
  const char* root = std::getenv(kStateRootVariable);
  if (root == nullptr || *root == '\0') return "/";
  return root;
}

machine_state read_machine_state(const std::filesystem::path& root) {
  machine_state state;
  state.root = root;
  const fs::path cpu_directory = root / kCpuDirectory;
  if (auto online = cpu_list_in(cpu_directory / "online"); online && !online->empty()) {
    state.cpus = std::move(*online);
  } else {
    state.cpus = numbered_entries(cpu_directory, "cpu");
  }
  for (unsigned cpu : state.cpus) state.frequencies.push_back(read_cpu_frequency(root, cpu));
  state.pstate_status = read_pstate_status(root);
  state.boost = read_boost(root, state.cpus);
  state.smt_control = word_or_unavailable(cpu_directory / "smt" / "control");
  state.smt_active = word_or_unavailable(cpu_directory / "smt" / "active");
  state.isolated = cpu_list_in(cpu_directory / "isolated");
  state.nohz_full = cpu_list_in(cpu_directory / "nohz_full");
  state.irqs = read_irqs(root);
  const fs::path huge_pages = root / "sys" / "kernel" / "mm" / "transparent_hugepage";
  state.transparent_hugepage = bracketed_choice(huge_pages / "enabled");
  state.transparent_hugepage_defrag = bracketed_choice(huge_pages / "defrag");
  return state;
}

std::optional<irq_summary> irqs_on(const machine_state& state, const std::vector<unsigned>& cpus) {
  if (!state.irqs) return std::nullopt;
  const std::vector<unsigned> wanted = sorted_unique(cpus);
  irq_summary summary;
  std::vector<unsigned> effective;
  bool any_effective = false;
  for (const auto& line : *state.irqs) {
    if (!line.allowed) continue;
    ++summary.total;
    if (meets(*line.allowed, wanted)) summary.allowed.push_back(line.irq);
    if (line.effective) {
      any_effective = true;
      if (meets(*line.effective, wanted)) effective.push_back(line.irq);
    }
  }
  if (any_effective) summary.effective = std::move(effective);
  return summary;
}

// --- The frequency during a command ---------------------------------------

frequency_trace::frequency_trace(std::filesystem::path root, std::vector<unsigned> cpus)
    : root_(std::move(root)), cpus_(std::move(cpus)) {
  std::vector<unsigned> readable;
  for (unsigned cpu : cpus_)
    if (number_in(policy_of(root_, cpu) / "scaling_cur_freq")) readable.push_back(cpu);
  cpus_ = std::move(readable);
  available_ = !cpus_.empty();
  sample();
}

void frequency_trace::sample() {
  ++samples_;
  if (!available_) return;
  for (unsigned cpu : cpus_)
    if (const auto khz = number_in(policy_of(root_, cpu) / "scaling_cur_freq")) readings_khz_.push_back(*khz);
}

frequency_summary frequency_trace::summary() const {
  frequency_summary summary;
  summary.cpus = cpus_;
  summary.samples = samples_;
  if (readings_khz_.empty()) return summary;
  std::vector<std::uint64_t> sorted = readings_khz_;
  std::sort(sorted.begin(), sorted.end());
  summary.lowest_khz = sorted.front();
  summary.median_khz = sorted[sorted.size() / 2];
  summary.highest_khz = sorted.back();
  return summary;
}

namespace {

std::mutex command_trace_mutex;
std::optional<frequency_trace> command_trace;  // guarded by command_trace_mutex

}  // namespace

void begin_command_frequency_trace() {
  const std::lock_guard lock(command_trace_mutex);
  command_trace.emplace(state_root(), affinity_cpus());
}

void sample_command_frequency() {
  const std::lock_guard lock(command_trace_mutex);
  if (command_trace) command_trace->sample();
}

frequency_summary command_frequency_summary() {
  const std::lock_guard lock(command_trace_mutex);
  if (!command_trace) command_trace.emplace(state_root(), affinity_cpus());
  else command_trace->sample();
  return command_trace->summary();
}

// --- An SMT sibling busy ----------------------------------------------------

std::vector<cpu_times> parse_proc_stat(std::string_view text) {
  std::vector<cpu_times> times;
  std::istringstream lines{std::string(text)};
  std::string line;
  while (std::getline(lines, line)) {
    if (line.rfind("cpu", 0) != 0 || line.size() < 4 || line[3] < '0' || line[3] > '9') continue;
    std::istringstream fields(line);
    std::string name;
    fields >> name;
    const auto cpu = number_named(name, "cpu");
    if (!cpu) continue;
    // user nice system idle iowait irq softirq steal (guest and guest_nice are inside user and nice)
    std::uint64_t value[8] = {};
    int read = 0;
    while (read < 8 && fields >> value[read]) ++read;
    if (read < 4) continue;
    const std::uint64_t busy = value[0] + value[1] + value[2] + value[5] + value[6];
    times.push_back({*cpu, busy, busy + value[3] + value[4] + value[7]});
  }
  return times;
}

std::vector<cpu_times> read_cpu_times(const std::filesystem::path& root) {
  std::ifstream file(root / "proc" / "stat");
  std::ostringstream text;
  text << file.rdbuf();
  return parse_proc_stat(text.str());
}

std::vector<unsigned> busy_smt_siblings(const std::vector<std::vector<unsigned>>& cores,
                                        const std::vector<unsigned>& team, const std::vector<cpu_times>& before,
                                        const std::vector<cpu_times>& after, double share) {
  const auto times_of = [](const std::vector<cpu_times>& times, unsigned cpu) -> const cpu_times* {
    for (const auto& entry : times)
      if (entry.cpu == cpu) return &entry;
    return nullptr;
  };
  const std::vector<unsigned> members = sorted_unique(team);
  std::vector<unsigned> busy;
  for (const auto& core : cores) {
    if (!meets(sorted_unique(core), members)) continue;
    for (unsigned sibling : core) {
      if (std::binary_search(members.begin(), members.end(), sibling)) continue;
      const cpu_times* start = times_of(before, sibling);
      const cpu_times* end = times_of(after, sibling);
      if (start == nullptr || end == nullptr || end->total <= start->total || end->busy < start->busy) continue;
      const double busy_share =
          static_cast<double>(end->busy - start->busy) / static_cast<double>(end->total - start->total);
      if (busy_share >= share) busy.push_back(sibling);
    }
  }
  return sorted_unique(busy);
}

// --- The bias line -----------------------------------------------------------

namespace {

// One thing that biases the figures: what is so, what it does, what to
// change and the command that changes it.
struct bias_part {
  std::string what;
  std::string effect;
  std::string change;
  std::string command;
};

std::string joined(const std::vector<std::string>& parts, const std::string& separator) {
  std::string text;
  for (const auto& part : parts) {
    if (part.empty()) continue;
    if (!text.empty()) text += separator;
    text += part;
  }
  return text;
}

// "a", "a and b", "a, b and c" (empty parts left out).
std::string listed(const std::vector<std::string>& parts) {
  std::vector<std::string> present;
  for (const auto& part : parts)
    if (!part.empty()) present.push_back(part);
  if (present.size() <= 1) return joined(present, "");
  const std::string last = present.back();
  present.pop_back();
  return joined(present, ", ") + " and " + last;
}

std::string cpus_words(const std::vector<unsigned>& cpus) {
  return fmt::format("{} {}", cpus.size() == 1 ? "CPU" : "CPUs", format_cpu_list(cpus));
}

const cpu_frequency* frequency_of(const machine_state& state, unsigned cpu) {
  for (const auto& reading : state.frequencies)
    if (reading.cpu == cpu) return &reading;
  return nullptr;
}

// The governors other than performance that the team's CPUs run, and the CPUs.
void governor_parts(const machine_state& state, const std::vector<unsigned>& team, std::vector<bias_part>& parts) {
  std::vector<unsigned> cpus;
  std::vector<std::string> governors;
  for (unsigned cpu : team) {
    const cpu_frequency* reading = frequency_of(state, cpu);
    if (reading == nullptr || reading->governor == kUnavailable) continue;
    if (reading->governor == "performance" || reading->governor == "userspace") continue;
    cpus.push_back(cpu);
    if (std::find(governors.begin(), governors.end(), reading->governor) == governors.end())
      governors.push_back(reading->governor);
  }
  const bool boost_on = state.boost.setting == boost_setting::on;
  const std::string boost_words = fmt::format("{} on", state.boost.word);
  if (!cpus.empty()) {
    parts.push_back({fmt::format("{} run the {} governor{}{}", cpus_words(cpus), listed(governors),
                                 governors.size() == 1 ? "" : "s", boost_on ? " with " + boost_words : ""),
                     "figures move with frequency", "set the performance governor",
                     "cpupower frequency-set -g performance"});
  } else if (boost_on) {
    parts.push_back({fmt::format("{} run with {}", cpus_words(team), boost_words), "figures move with frequency",
                     "", ""});
  }
  if (boost_on) parts.push_back({"", "", fmt::format("turn {} off", state.boost.word), state.boost.turn_off});
}

void latency_parts(const machine_state& state, const std::vector<unsigned>& team, std::vector<bias_part>& parts) {
  std::vector<unsigned> not_isolated;
  if (state.isolated) {
    for (unsigned cpu : team)
      if (!std::binary_search(state.isolated->begin(), state.isolated->end(), cpu)) not_isolated.push_back(cpu);
  }
  std::vector<unsigned> ticking;
  if (state.nohz_full) {
    for (unsigned cpu : team)
      if (!std::binary_search(state.nohz_full->begin(), state.nohz_full->end(), cpu)) ticking.push_back(cpu);
  }
  if (!not_isolated.empty()) {
    parts.push_back({fmt::format("{} {} not isolated", cpus_words(not_isolated), not_isolated.size() == 1 ? "is" : "are"),
                     "other tasks share them", "isolate them",
                     fmt::format("isolcpus={}", format_cpu_list(not_isolated))});
  }
  if (!ticking.empty()) {
    const bool same = ticking == not_isolated;
    parts.push_back({same ? "the tick runs on them" : fmt::format("the tick runs on {}", cpus_words(ticking)),
                     "the tick interrupts the step", "stop the tick there",
                     fmt::format("nohz_full={}", format_cpu_list(ticking))});
  }
}

}  // namespace

std::string bias_line(const machine_state& state, const std::vector<unsigned>& team, bias_focus focus,
                      const std::vector<unsigned>& busy_siblings) {
  const std::vector<unsigned> members = sorted_unique(team);
  if (members.empty()) return {};
  std::vector<bias_part> parts;
  if (focus == bias_focus::step_times) {
    governor_parts(state, members, parts);
    if (!busy_siblings.empty()) {
      const bool one = busy_siblings.size() == 1;
      parts.push_back({fmt::format("the SMT {} {} of the measured CPUs {} busy", one ? "sibling" : "siblings",
                                   format_cpu_list(busy_siblings), one ? "was" : "were"),
                       "a busy sibling takes part of its core", "leave the siblings idle or turn SMT off",
                       "echo off > /sys/devices/system/cpu/smt/control"});
    }
  } else {
    latency_parts(state, members, parts);
  }
  std::vector<std::string> what;
  std::vector<std::string> effects;  // each once
  std::vector<std::string> changes;
  std::vector<std::string> commands;
  for (const auto& part : parts) {
    what.push_back(part.what);
    if (std::find(effects.begin(), effects.end(), part.effect) == effects.end()) effects.push_back(part.effect);
    changes.push_back(part.change);
    commands.push_back(part.command);
  }
  if (joined(what, "").empty()) return {};
  // Kernel parameters go on one command line.
  const bool kernel_parameters = focus == bias_focus::wake_up_latency;
  const std::string command_text =
      kernel_parameters ? joined(commands, " ") + " on the kernel command line" : joined(commands, "; ");
  return fmt::format("{}: {}; {} ({})", listed(what), listed(effects), listed(changes), command_text);
}

}  // namespace lockstep::platform
