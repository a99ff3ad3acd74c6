#pragma once
// Runs a command line as a user would, and captures what it printed and how it
// exited. For the cli tests of the lockstep binary.
#include <sys/wait.h>
#include <fcntl.h>
#include <spawn.h>
#include <unistd.h>

#include <array>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace lockstep::testing {

struct command_result {
  int exit_status = -1;  // the exit status, or 128 + signal when killed
  std::string out;
  std::string err;
};

namespace detail {
inline std::string slurp(int fd) {
  std::string text;
  std::array<char, 4096> buffer{};
  ssize_t n = 0;
  while ((n = ::read(fd, buffer.data(), buffer.size())) > 0) text.append(buffer.data(), static_cast<std::size_t>(n));
  ::close(fd);
  return text;
}
}  // namespace detail

// Runs argv[0] with the given arguments; stdout and stderr go to temporary
// files (so that a chatty command cannot fill a pipe and block).
inline command_result run_command(const std::vector<std::string>& argv) {
  char out_name[] = "/tmp/lockstep-test-out-XXXXXX";
  char err_name[] = "/tmp/lockstep-test-err-XXXXXX";
  const int out_fd = ::mkstemp(out_name);
  const int err_fd = ::mkstemp(err_name);
  if (out_fd < 0 || err_fd < 0) throw std::runtime_error("mkstemp failed");

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out_fd, STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, err_fd, STDERR_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);

  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);

  pid_t pid = 0;
  const int spawn_error = ::posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawn_error != 0) throw std::runtime_error("cannot start " + argv[0]);

  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
  }
  command_result result;
  result.exit_status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  ::lseek(out_fd, 0, SEEK_SET);
  ::lseek(err_fd, 0, SEEK_SET);
  result.out = detail::slurp(out_fd);
  result.err = detail::slurp(err_fd);
  ::unlink(out_name);
  ::unlink(err_name);
  return result;
}

// Lines in a text (a trailing newline does not make an empty last line).
inline int count_lines(const std::string& text) {
  int lines = 0;
  for (char c : text) lines += c == '\n';
  if (!text.empty() && text.back() != '\n') ++lines;
  return lines;
}

}  // namespace lockstep::testing
