#include "distributed/registry.hpp"

#include <algorithm>
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
    exchange_entry{"p2p", "", "p2p", "exchange:p2p",
                   "dataflow: nonblocking sends to the ranks that read the block, receives (posted before the stage's arithmetic) from the ranks it reads",
                   always, make<p2p_exchange>},
    exchange_entry{"allgather", "", "allgather", "exchange:allgather", "one MPI_Allgatherv per stage: every block to every rank",
                   always, make<allgather_exchange>},
    exchange_entry{"rma_put", "", "rma_put", "exchange:rma_put",
                   "one-sided: MPI_Put into the readers' windows, flush, then a flag (passive target)", always,
                   make<rma_put_exchange>},
    exchange_entry{"shm_window", "futex_spin", "shm_window/futex_spin", "exchange:shm_window/sync:futex_spin",
                   "one MPI-3 shared window, stage values read in place, futex_spin across processes (shared futexes)",
                   one_host_without_tcp, make<shm_window_exchange>},
    exchange_entry{"shm_window", "mailbox", "shm_window/mailbox", "exchange:shm_window/sync:mailbox",
                   "one MPI-3 shared window holding lockstep's mailbox: dataflow between processes (shared futexes)",
                   one_host_without_tcp, make<shm_mailbox_exchange>},
};

}  // namespace

std::string_view to_string(transport how) noexcept { return how == transport::tcp ? "tcp" : "shm"; }

std::span<const exchange_entry> exchanges() noexcept { return kExchanges; }

namespace {
template <class Field>
std::vector<std::string> distinct(Field field) {
  std::vector<std::string> values;
  for (const exchange_entry& entry : kExchanges) {
    const std::string value(entry.*field);
    if (!value.empty() && std::find(values.begin(), values.end(), value) == values.end()) values.push_back(value);
  }
  return values;
}
}  // namespace

std::vector<std::string> exchange_names() { return distinct(&exchange_entry::name); }
std::vector<std::string> exchange_syncs() { return distinct(&exchange_entry::sync); }

}  // namespace lockstep::distributed
