// lockstep: one binary, one subcommand per job (README.md, Commands).
#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include <cstdio>
#include <exception>
#include <string>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "bench/results/build_info.hpp"
#include "platform/machine_state.hpp"

namespace {

// `lockstep help [COMMAND]`: the same text as `lockstep COMMAND --help`;
// `lockstep help` alone, the same as `lockstep --help`.
// compare and report are CLI11 prefix commands (bench/cli/reports.cpp) whose
// help is their Python tool's, so theirs is that tool's --help.
void add_help(CLI::App& app, int& result) {
  auto* help = app.add_subcommand("help", "Show the help of lockstep or of one command");
  auto command = std::make_shared<std::string>();
  help->add_option("command", *command, "The command to describe");
  help->callback([&app, command, &result] {
    if (command->empty()) {
      // The overview, as `lockstep --help` prints it: app.help() would hand
      // over to the selected subcommand, this one.
      fmt::print("{}", app.get_formatter()->make_help(&app, app.get_name(), CLI::AppFormatMode::Normal));
      result = lockstep::cli::kExitOk;
      return;
    }
    CLI::App* sub = nullptr;
    try {
      sub = app.get_subcommand(*command);
    } catch (const CLI::OptionNotFound&) {
      throw lockstep::cli::usage_error(lockstep::cli::unknown_command_message(app, *command));
    }
    if (sub->get_prefix_command()) lockstep::cli::exec_reports_help(sub->get_name());
    fmt::print("{}", sub->help(app.get_name()));
    result = lockstep::cli::kExitOk;
  });
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "lockstep: the coupled-oscillator RK4 step as a benchmark of multi-core delay\n"
      "(synchronisation primitives x data layouts x thread placements)",
      "lockstep"};
  app.set_version_flag("--version", fmt::format("lockstep {} (result schema {}, {})",
                                                lockstep::build_info::kVersion,
                                                lockstep::build_info::kResultSchema,
                                                lockstep::build_info::git_revision()));
  app.require_subcommand(1);

  int result = lockstep::cli::kExitOk;
  lockstep::cli::add_run(app, result);
  lockstep::cli::add_verify(app, result);
  lockstep::cli::add_c2c(app, result);
  lockstep::cli::add_delay(app, result);
  lockstep::cli::add_falseshare(app, result);
  lockstep::cli::add_migrate(app, result);
  lockstep::cli::add_mpi(app, result);
  lockstep::cli::add_topology(app, result);
  lockstep::cli::add_list(app, result);
  lockstep::cli::add_reports(app, result);
  add_help(app, result);

  // The frequency during the command: its first sample (platform/machine_state.hpp).
  lockstep::platform::begin_command_frequency_trace();
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // A mistyped command or option first, with the nearest valid spelling
    // (bench/cli/options.hpp: unknown_word_message); else CLI11's own line.
    const std::string unknown = lockstep::cli::unknown_word_message(app);
    fmt::print(stderr, "lockstep: {}\n", unknown.empty() ? std::string(e.what()) : unknown);
    return lockstep::cli::kExitUsage;
  } catch (const lockstep::cli::usage_error& e) {
    fmt::print(stderr, "lockstep: {}\n", e.what());
    return lockstep::cli::kExitUsage;
  } catch (const std::exception& e) {
    fmt::print(stderr, "lockstep: internal error: {}\n", e.what());
    return 3;
  }
  return result;
}
