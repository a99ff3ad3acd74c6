// lockstep migrate: not built yet (see the open issues).
#include <CLI/CLI.hpp>

#include "bench/command.hpp"

namespace lockstep::cli {

void add_migrate(CLI::App& app, int& result) {
  (void)app;
  (void)result;
}

}  // namespace lockstep::cli
