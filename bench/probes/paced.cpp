// The paced RK4 step (paced.hpp): the dispatch from names to the composed step.
#include "bench/probes/paced.hpp"

#include <stdexcept>

#include "kernels/oscillator.hpp"
#include "kernels/parallel_step.hpp"
#include "layouts/registry.hpp"
#include "sync/registry.hpp"
#include "sync/team.hpp"

namespace lockstep::bench::probes {
namespace {

// The model's time step. Fixed rather than tied to the period: the delay
// measured must not depend on the physics, and 0.1 ms keeps omega * dt about
// 0.005 for the paper's fastest mode (RK4 is stable far beyond), whatever
// period is chosen.
constexpr double kStepSeconds = 1e-4;

template <class Sync, class Layout>
paced_result run_combination(unsigned threads, const platform::placement_plan& plan, const paced_settings& settings) {
  const kernels::two_mass_model model;
  kernels::parallel_rk4<Sync, Layout> step(model, kStepSeconds, threads);
  std::vector<sync::participant> participants(threads);
  for (unsigned id = 0; id < threads; ++id) participants[id].id = id;
  sync::team_of_t<Sync> team(threads);
  return run_paced(
      team, threads, settings, [&](unsigned id) { platform::pin_current_thread(plan, id); },
      [&](unsigned id, std::uint64_t period) {
        // migrate: the move happens inside the period it is due in, so its
        // cost lands in that period's completion time (the point of it).
        if (plan.moves_at(period)) {
          try {
            platform::pin_current_thread(plan, id, period);
          } catch (const std::exception&) {
            // the placement was checked at the first pin; a refusal now only
            // leaves this thread where it is for one more period
          }
        }
        step.run(participants[id], 1);
      });
}

// Calls visit.template operator()<Sync, Layout>() for the named pair when it
// applies; returns why not otherwise (empty: visited).
template <class Visitor>
std::string with_combination(const std::string& sync_name, const std::string& layout_name, unsigned threads,
                             Visitor&& visit) {
  if (sync::find_primitive(sync_name) == nullptr) {
    std::string names;
    for (const auto& info : sync::all_primitive_info) names += (names.empty() ? "" : ", ") + std::string(info.name);
    return "unknown primitive '" + sync_name + "' (valid: " + names + ")";
  }
  if (layouts::find_layout(layout_name) == nullptr) {
    std::string names;
    for (const auto& info : layouts::all_layout_info) names += (names.empty() ? "" : ", ") + std::string(info.name);
    return "unknown layout '" + layout_name + "' (valid: " + names + ")";
  }
  std::string problem;
  sync::for_each_primitive([&]<class Sync>() {
    if (Sync::kName != sync_name) return;
    layouts::for_each_layout([&]<class Layout>() {
      if (Layout::kName != layout_name) return;
      const kernels::two_mass_model model;
      const std::string reason = kernels::not_applicable_reason<Sync, Layout>(model.equations(), threads);
      if (!reason.empty()) {
        problem = sync_name + " on " + layout_name + " with " + std::to_string(threads) +
                  " threads does not run: " + reason;
        return;
      }
      if constexpr (kernels::applicable<Sync, Layout>().applicable) visit.template operator()<Sync, Layout>();
    });
  });
  return problem;
}

}  // namespace

std::string paced_step_problem(const std::string& sync, const std::string& layout, unsigned threads) {
  return with_combination(sync, layout, threads, []<class, class>() {});
}

paced_result run_paced_step(const paced_step_settings& settings, const platform::placement_plan& plan) {
  paced_result result;
  const std::string problem =
      with_combination(settings.sync, settings.layout, settings.threads, [&]<class Sync, class Layout>() {
        result = run_combination<Sync, Layout>(settings.threads, plan, settings.pacing);
      });
  if (!problem.empty()) throw std::invalid_argument(problem);
  return result;
}

}  // namespace lockstep::bench::probes
