#pragma once
// The readings of a verification (kernels/verification.hpp: run_verification
// computes every figure and check of a kernels::verify_report): the text a
// person reads, the trajectory as CSV (--csv) and the result file
// (docs/result-files.md, kind "verify"). They only arrange the report.
#include <nlohmann/json.hpp>

#include <string>

#include "kernels/verification.hpp"
#include "platform/topology.hpp"

namespace lockstep::bench {

// The whole text of the answer (stdout): the model, its roots, the ladder,
// energy, dopri5 and every check.
std::string verify_text(const kernels::verify_report& report);

// The trajectory at the step: a header `t,x1,...,xS`, one line per point.
std::string verify_csv(const kernels::verify_report& report);

// The result file's document (kind "verify"), the machine context included.
nlohmann::json verify_json(const kernels::verify_report& report, const platform::topology& machine);

}  // namespace lockstep::bench
