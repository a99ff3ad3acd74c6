// lockstep compare, lockstep report: the result tools written in Python
// (reports/, reports/README.md). These two subcommands only locate the
// Python entry point and exec Debian's interpreter on it with every argument
// passed through untouched, so that the Python tool owns its own options,
// its own --help, and its own exit status (0 ok, 1 regression beyond
// --fail-above, 2 bad input).
//
// Why /usr/bin/python3 and not `python3` from PATH: a pyenv python3 may come
// first on PATH and cannot import Debian's numpy, scipy and matplotlib.
//
// Where reports/ is: the directory named by LOCKSTEP_REPORTS_DIR (a test that
// points at another checkout); else share/lockstep/reports beside the binary's
// bin/, where an installed copy or a bundle (scripts/bundle.sh) carries it;
// else the source tree this binary was configured from
// (build_info::kSourceDir). LOCKSTEP_PYTHON overrides the interpreter.
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/results/build_info.hpp"

namespace lockstep::cli {
namespace {

constexpr const char* kDefaultPython = "/usr/bin/python3";
constexpr const char* kEntryScript = "cli.py";

std::string environment_or(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return (value != nullptr && *value != '\0') ? std::string(value) : fallback;
}

// The reports/ directory, in the order the comment at the top gives.
std::string reports_directory() {
  if (const char* named = std::getenv("LOCKSTEP_REPORTS_DIR"); named != nullptr && *named != '\0') return named;
  std::error_code error;
  const std::filesystem::path binary = std::filesystem::read_symlink("/proc/self/exe", error);
  if (!error) {
    const std::filesystem::path installed = binary.parent_path().parent_path() / "share/lockstep/reports";
    if (std::filesystem::exists(installed / kEntryScript, error)) return installed.string();
  }
  return std::string(build_info::kSourceDir) + "/reports";
}

// Replaces this process with `python3 reports/cli.py <tool> <arguments...>`.
// Returns only by throwing: exec failed, or the entry point is missing.
[[noreturn]] void exec_python_tool(const std::string& tool, const std::vector<std::string>& arguments) {
  const std::string reports_dir = reports_directory();
  const std::string python = environment_or("LOCKSTEP_PYTHON", kDefaultPython);
  const std::string script = reports_dir + "/" + kEntryScript;

  if (::access(script.c_str(), R_OK) != 0) {
    throw usage_error(fmt::format("cannot find the report tools at {} ({}); set LOCKSTEP_REPORTS_DIR to the "
                                  "reports/ directory of a lockstep checkout",
                                  script, std::strerror(errno)));
  }
  if (::access(python.c_str(), X_OK) != 0) {
    throw usage_error(fmt::format("cannot run {} ({}): compare and report need Python 3 with Debian's "
                                  "python3-numpy python3-scipy python3-matplotlib python3-jinja2 python3-jsonschema "
                                  "(LOCKSTEP_PYTHON names another interpreter); the measuring commands do not",
                                  python, std::strerror(errno)));
  }

  std::vector<std::string> words{python, script, tool};
  words.insert(words.end(), arguments.begin(), arguments.end());
  std::vector<char*> argv;
  argv.reserve(words.size() + 1);
  for (auto& word : words) argv.push_back(word.data());
  argv.push_back(nullptr);

  std::fflush(stdout);
  std::fflush(stderr);
  ::execv(python.c_str(), argv.data());
  throw usage_error(fmt::format("cannot run {}: {}", python, std::strerror(errno)));
}

// One pass-through subcommand: no options of its own (not even --help, which
// the Python tool answers), everything after the name goes to Python in order.
void add_pass_through(CLI::App& app, const std::string& name, const std::string& description) {
  auto* command = app.add_subcommand(name, description);
  command->set_help_flag();  // `lockstep compare --help` is the Python tool's help
  command->allow_extras();
  command->prefix_command();
  command->callback([command, name] { exec_python_tool(name, command->remaining()); });
}

}  // namespace

void exec_reports_help(const std::string& tool) { exec_python_tool(tool, {"--help"}); }

void add_reports(CLI::App& app, int& result) {
  (void)result;  // the exec'd tool's exit status is the process's exit status
  add_pass_through(app, "compare",
                   "Compare result files across runs and machines: each entry's ratio of medians B/A, called "
                   "slower or faster only when its exact 95 % interval lies beyond the noise band (--noise, "
                   "default 5 %), Mann-Whitney U p-values with Benjamini-Hochberg's adjustment, pace-aware "
                   "verdicts, the machines' fingerprints (`lockstep compare --help` for the options)");
  add_pass_through(app, "report",
                   "HTML + Markdown report with figures from result files (run, c2c, delay, mpi, verify --csv) "
                   "(`lockstep report --help` for the options)");
}

}  // namespace lockstep::cli
