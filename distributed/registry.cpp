#include "distributed/registry.hpp"

#include <array>

#include "distributed/allgather.hpp"
#include "distributed/p2p.hpp"
#include "distributed/rma_put.hpp"
#include "distributed/shm_window.hpp"

namespace lockstep::distributed {
namespace {

std::string always(const job_shape& /*job*/) { return {}; }

std::string one_host_without_tcp(const job_shape& job) {
  if (job.hosts != 1)
    return "the ranks span " + std::to_string(job.hosts) + " hosts: a shared-memory window needs them on one";
  if (job.how == transport::tcp) return "--transport tcp measures the network path, which a shared window bypasses";
  if (job.ranks > static_cast<int>(sync::process_shared_futex_spin::kSharedParticipantsMax))
    return "more ranks than the process-shared futex_spin holds (" +
           std::to_string(sync::process_shared_futex_spin::kSharedParticipantsMax) + ")";
  return {};
}

template <class Exchange>
std::unique_ptr<exchange> make(const exchange_setup& setup) {
  return std::make_unique<Exchange>(setup);
}

constexpr std::array kExchanges{
    exchange_entry{"p2p", "exchange:p2p",
                   "dataflow: nonblocking sends to the ranks that read the block, receives from the ranks it reads",
                   always, make<p2p_exchange>},
    exchange_entry{"allgather", "exchange:allgather", "one MPI_Allgatherv per stage: every block to every rank",
                   always, make<allgather_exchange>},
    exchange_entry{"rma_put", "exchange:rma_put",
                   "one-sided: MPI_Put into the readers' windows, flush, then a flag (passive target)", always,
                   make<rma_put_exchange>},
    exchange_entry{"shm_window", "exchange:shm_window/sync:futex_spin",
                   "one MPI-3 shared window, stage values read in place, futex_spin across processes (shared futexes)",
                   one_host_without_tcp, make<shm_window_exchange>},
};

}  // namespace

std::string_view to_string(transport how) noexcept { return how == transport::tcp ? "tcp" : "shm"; }

std::span<const exchange_entry> exchanges() noexcept { return kExchanges; }

std::vector<std::string> exchange_names() {
  std::vector<std::string> names;
  for (const exchange_entry& entry : kExchanges) names.emplace_back(entry.name);
  return names;
}

const exchange_entry* find_exchange(std::string_view name) noexcept {
  for (const exchange_entry& entry : kExchanges)
    if (entry.name == name) return &entry;
  return nullptr;
}

}  // namespace lockstep::distributed
