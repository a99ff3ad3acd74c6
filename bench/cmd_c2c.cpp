// lockstep c2c: not built yet (see the open issues).
#include <CLI/CLI.hpp>

#include "bench/command.hpp"

namespace lockstep::cli {

void add_c2c(CLI::App& app, int& result) {
  (void)app;
  (void)result;
}

}  // namespace lockstep::cli
