// Paired ratios: the comparison kinds' names (paired_ratio.hpp).
#include "bench/results/paired_ratio.hpp"

namespace lockstep::bench {

std::string_view to_string(comparison_kind kind) noexcept {
  switch (kind) {
    case comparison_kind::false_sharing:
      return "false_sharing";
    case comparison_kind::migration:
      return "migration";
    case comparison_kind::against_best_other:
      return "against_best_other";
    case comparison_kind::crossover:
      return "crossover";
  }
  return "false_sharing";
}

}  // namespace lockstep::bench
