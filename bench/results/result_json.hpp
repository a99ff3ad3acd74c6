#pragma once
// The shapes every result JSON shares (c2c, delay, falseshare, migrate, mpi): a
// distribution and a histogram, written the same way by every command and
// read by reports/lockstep_reports/read/inputs.py.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <vector>

#include "platform/distribution_json.hpp"
#include "platform/stats.hpp"

namespace lockstep::bench {

// {min, p50, p99, p999, max, mean, count}: platform/distribution_json.hpp's.
using platform::distribution_json;

// The histogram of these samples (round bucket widths covering min..max, see
// platform/stats.hpp), every sample added.
platform::histogram histogram_of(const std::vector<double>& samples, std::size_t max_buckets = 50);

// {bucket_ns, first_ns, counts, below, above}.
nlohmann::json histogram_json(const platform::histogram& histogram);

}  // namespace lockstep::bench
