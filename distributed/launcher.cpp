#include "distributed/launcher.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace lockstep::distributed {
namespace {

// A word that sh reads as itself is shown bare; anything else in single
// quotes. '=' is not in the bare set: a leading NAME=value word is an
// assignment to sh, not the command (--mpirun A=b/mpirun).
std::string quoted(const std::string& word) {
  if (!word.empty() && word.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_./,:@+") ==
                           std::string::npos)
    return word;
  std::string result = "'";
  for (char c : word) {
    if (c == '\'')
      result += "'\\''";
    else
      result += c;
  }
  return result + "'";
}

}  // namespace

bool launched_by_mpi() {
  for (const char* variable : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE", "MPI_LOCALNRANKS"})
    if (std::getenv(variable) != nullptr) return true;
  return false;
}

std::string launch_plan::shown() const {
  std::string text;
  for (const auto& [name, value] : environment) text += name + "=" + quoted(value) + " ";
  for (std::size_t index = 0; index < argv.size(); ++index) {
    if (index != 0) text += ' ';
    text += quoted(argv[index]);
  }
  return text;
}

launch_plan plan_launch(const launch_request& request) {
  launch_plan plan;
  plan.argv.push_back(request.mpirun);
  if (!request.network.empty() && request.hostfile.empty())
    throw std::invalid_argument("--network names the network between hosts: it needs --hostfile");
  if (request.open_mpi) {
    plan.argv.insert(plan.argv.end(), {"--np", std::to_string(request.ranks)});
    if (!request.hostfile.empty()) plan.argv.insert(plan.argv.end(), {"--hostfile", request.hostfile});
    if (request.hostfile.empty() && request.ranks > request.host_cpus) plan.argv.emplace_back("--oversubscribe");
    plan.argv.insert(plan.argv.end(), {"--bind-to", "none", "--mca", "pml", "ob1"});
    if (!request.hostfile.empty()) {
      plan.argv.insert(plan.argv.end(), {"--map-by", "node", "--mca", "btl",
                                         request.how == transport::tcp ? "self,tcp" : "self,vader,tcp", "--mca",
                                         "btl_vader_single_copy_mechanism", "none", "--mca", "osc",
                                         request.how == transport::tcp ? "pt2pt" : "sm,pt2pt"});
      if (!request.network.empty())
        plan.argv.insert(plan.argv.end(), {"--mca", "btl_tcp_if_include", request.network, "--mca",
                                           "oob_tcp_if_include", request.network});
      const std::string keepalive = std::to_string(std::max<std::int64_t>(1, request.watchdog_ns / 4'000'000'000));
      plan.argv.insert(plan.argv.end(), {"--mca", "oob_tcp_keepalive_time", keepalive, "--mca",
                                         "oob_tcp_keepalive_intvl", keepalive, "--mca", "oob_tcp_keepalive_probes", "1"});
    } else if (request.how == transport::tcp) {
      // osc pt2pt: one-sided traffic over the same btl (osc sm would take the
      // shared memory of one host and bypass TCP).
      plan.argv.insert(plan.argv.end(),
                       {"--mca", "btl", "self,tcp", "--mca", "btl_tcp_if_include", "lo", "--mca", "osc", "pt2pt"});
    } else {
      plan.argv.insert(plan.argv.end(),
                       {"--mca", "btl", "self,vader", "--mca", "btl_vader_single_copy_mechanism", "none"});
    }
    for (const std::string& variable : request.forwarded) plan.argv.insert(plan.argv.end(), {"-x", variable});
    if (request.as_root) {
      plan.environment.emplace_back("OMPI_ALLOW_RUN_AS_ROOT", "1");
      plan.environment.emplace_back("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1");
    }
  } else {
    if (request.how == transport::tcp || !request.network.empty())
      throw std::invalid_argument(std::string(request.how == transport::tcp ? "--transport tcp" : "--network") +
                                  " needs Open MPI's mpirun (" + request.mpirun +
                                  " is another MPI's, which chooses its own transport)");
    plan.argv.insert(plan.argv.end(), {"-n", std::to_string(request.ranks)});
    if (!request.hostfile.empty()) plan.argv.insert(plan.argv.end(), {"-f", request.hostfile});
  }
  plan.argv.push_back(request.executable);
  plan.argv.insert(plan.argv.end(), request.arguments.begin(), request.arguments.end());
  return plan;
}

std::optional<std::string> find_program(std::string_view name) {
  if (name.find('/') != std::string_view::npos) {
    const std::string path(name);
    if (access(path.c_str(), X_OK) == 0) return path;
    return std::nullopt;
  }
  const char* path_variable = std::getenv("PATH");
  if (path_variable == nullptr) return std::nullopt;
  std::stringstream directories(path_variable);
  std::string directory;
  while (std::getline(directories, directory, ':')) {
    if (directory.empty()) continue;
    const std::string candidate = directory + "/" + std::string(name);
    if (access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return std::nullopt;
}

bool is_open_mpi(const std::string& mpirun) {
  const std::string command = quoted(mpirun) + " --version 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return false;
  std::string output;
  std::array<char, 256> buffer{};
  while (std::fgets(buffer.data(), static_cast<int>(buffer.size()), pipe) != nullptr) output += buffer.data();
  pclose(pipe);
  return output.find("Open MPI") != std::string::npos || output.find("OpenRTE") != std::string::npos;
}

std::vector<std::string> read_hostfile(const std::string& path) {
  std::ifstream file(path);
  if (!file) throw std::invalid_argument("--hostfile: cannot read " + path + ": " + std::strerror(errno));
  std::vector<std::string> hosts;
  std::string line;
  while (std::getline(file, line)) {
    if (const auto comment = line.find('#'); comment != std::string::npos) line.resize(comment);
    std::istringstream words(line);
    std::string host;
    if (words >> host) hosts.push_back(host);
  }
  if (file.bad()) throw std::invalid_argument("--hostfile: reading " + path + " failed");
  if (hosts.empty()) throw std::invalid_argument("--hostfile: " + path + " names no host");
  return hosts;
}

int run_plan(const launch_plan& plan) {
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t child = fork();
  if (child < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
  if (child == 0) {
    for (const auto& [name, value] : plan.environment) setenv(name.c_str(), value.c_str(), 1);
    std::vector<char*> argv;
    for (const std::string& word : plan.argv) argv.push_back(const_cast<char*>(word.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    std::fprintf(stderr, "lockstep mpi: cannot run %s: %s\n", argv[0], std::strerror(errno));
    std::_Exit(127);
  }
  int status = 0;
  while (waitpid(child, &status, 0) < 0) {
    if (errno != EINTR) throw std::runtime_error(std::string("waitpid failed: ") + std::strerror(errno));
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

std::string this_executable() {
  std::array<char, PATH_MAX> buffer{};
  const ssize_t length = readlink("/proc/self/exe", buffer.data(), buffer.size() - 1);
  if (length <= 0) throw std::runtime_error("cannot read /proc/self/exe");
  return std::string(buffer.data(), static_cast<std::size_t>(length));
}

std::vector<std::string> own_arguments() {
  std::ifstream file("/proc/self/cmdline", std::ios::binary);
  if (!file) throw std::runtime_error("cannot read /proc/self/cmdline");
  std::vector<std::string> words;
  std::string word;
  while (std::getline(file, word, '\0')) words.push_back(word);
  if (words.empty()) throw std::runtime_error("/proc/self/cmdline is empty");
  words.erase(words.begin());  // the program name: the ranks run this_executable()
  return words;
}

}  // namespace lockstep::distributed
