#pragma once
// How a lockstep subcommand plugs into the one binary.
//
// Each command lives in a file of its own in bench/cli/, named for it
// (bench/cli/run.cpp holds `lockstep run`), and exposes one function,
// add_<name>(app, result), that adds its CLI11 subcommand and sets a callback.
// The callback stores the command's exit status in `result`:
//   0  success,
//   1  the command ran but what it checked does not hold (e.g. verify's bounds),
//   2  bad input (throw usage_error instead: main prints one line and exits 2).
#include <stdexcept>
#include <string>

namespace CLI {
class App;
}

namespace lockstep::cli {

// Bad input: an unknown name, a bad number, an unreadable or truncated file,
// a permission that is missing. main() prints "lockstep: <what>" on stderr and
// exits with status 2. The message is one line and says what to do instead.
class usage_error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

inline constexpr int kExitOk = 0;
inline constexpr int kExitCheckFailed = 1;
inline constexpr int kExitUsage = 2;

void add_verify(CLI::App& app, int& result);
void add_run(CLI::App& app, int& result);
void add_list(CLI::App& app, int& result);
void add_topology(CLI::App& app, int& result);
void add_c2c(CLI::App& app, int& result);
void add_delay(CLI::App& app, int& result);
void add_falseshare(CLI::App& app, int& result);
void add_migrate(CLI::App& app, int& result);
void add_mpi(CLI::App& app, int& result);  // the step across MPI ranks (distributed/)
void add_reports(CLI::App& app, int& result);  // compare and report (Python, reports/)

// `lockstep help compare`, `lockstep help report`: the Python tool's own
// --help, exactly as `lockstep compare --help` shows it (the process becomes
// the tool; returns only by throwing usage_error).
[[noreturn]] void exec_reports_help(const std::string& tool);

}  // namespace lockstep::cli
