#include "distributed/world.hpp"

#include <algorithm>
#include <set>
#include <stdexcept>

namespace lockstep::distributed {

mpi_session::mpi_session() {
  if (MPI_Init(nullptr, nullptr) != MPI_SUCCESS) throw std::runtime_error("MPI_Init failed");
}

mpi_session::~mpi_session() { MPI_Finalize(); }

world describe_world() {
  world result;
  MPI_Comm_rank(MPI_COMM_WORLD, &result.rank);
  MPI_Comm_size(MPI_COMM_WORLD, &result.size);
  MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, result.rank, MPI_INFO_NULL, &result.host_comm);
  MPI_Comm_rank(result.host_comm, &result.host_rank);
  MPI_Comm_size(result.host_comm, &result.host_size);

  // Hosts: the number of ranks that lead their host's communicator.
  const int leader = result.host_rank == 0 ? 1 : 0;
  MPI_Allreduce(&leader, &result.hosts, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  MPI_Allreduce(&result.host_size, &result.ranks_per_host_max, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);

  char name[MPI_MAX_PROCESSOR_NAME] = {};
  int length = 0;
  MPI_Get_processor_name(name, &length);
  result.host.assign(name, static_cast<std::size_t>(length));
  std::vector<char> names(static_cast<std::size_t>(result.size) * MPI_MAX_PROCESSOR_NAME, '\0');
  std::vector<char> mine(MPI_MAX_PROCESSOR_NAME, '\0');
  std::copy(result.host.begin(), result.host.end(), mine.begin());
  MPI_Allgather(mine.data(), MPI_MAX_PROCESSOR_NAME, MPI_CHAR, names.data(), MPI_MAX_PROCESSOR_NAME, MPI_CHAR,
                MPI_COMM_WORLD);
  for (int rank = 0; rank < result.size; ++rank)
    result.host_of_rank.emplace_back(names.data() + static_cast<std::size_t>(rank) * MPI_MAX_PROCESSOR_NAME);
  return result;
}

std::string library_version() {
  char text[MPI_MAX_LIBRARY_VERSION_STRING] = {};
  int length = 0;
  MPI_Get_library_version(text, &length);
  std::string version(text, static_cast<std::size_t>(length));
  if (const auto end = version.find_first_of("\r\n"); end != std::string::npos) version.resize(end);
  while (!version.empty() && (version.back() == ' ' || version.back() == ',')) version.pop_back();
  return version;
}

std::string standard_version() {
  int major = 0;
  int minor = 0;
  MPI_Get_version(&major, &minor);
  return std::to_string(major) + "." + std::to_string(minor);
}

}  // namespace lockstep::distributed
