// lockstep delay: not built yet (see the open issues).
#include <CLI/CLI.hpp>

#include "bench/command.hpp"

namespace lockstep::cli {

void add_delay(CLI::App& app, int& result) {
  (void)app;
  (void)result;
}

}  // namespace lockstep::cli
