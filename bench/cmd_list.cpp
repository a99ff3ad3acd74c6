// lockstep list: not built yet (see the open issues).
#include <CLI/CLI.hpp>

#include "bench/command.hpp"

namespace lockstep::cli {

void add_list(CLI::App& app, int& result) {
  (void)app;
  (void)result;
}

}  // namespace lockstep::cli
