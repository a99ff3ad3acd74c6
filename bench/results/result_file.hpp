#pragma once
// The one way lockstep writes a result file (every command: run, c2c, delay,
// falseshare, migrate, verify, topology): into a temporary file in the
// destination's own directory, fsync'd, then renamed over the destination.
// A reader sees the old file or the whole new one, never half of one; a
// failure (or SIGINT / SIGTERM) removes the temporary file.
//
// Bad destinations are found before any measurement: check_result_path
// creates and removes a probe file where the temporary file will go, so a
// missing or read-only directory, a directory given as the file, or a place
// where no file can be created (/proc) fails in a millisecond with one line.
#include <stdexcept>
#include <string>
#include <string_view>

namespace lockstep::bench {

// A destination that cannot be written; what() is one line naming the path
// and why ("cannot write results/x.json: the directory results does not
// exist"). Commands turn it into their bad-input exit (status 2).
class result_path_error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Throws result_path_error when `destination` cannot be written atomically.
// Creates nothing that stays.
void check_result_path(const std::string& destination);

// A result file being written. The constructor checks the destination
// (check_result_path) and creates the temporary file beside it, exclusively
// and without following a symbolic link (O_EXCL | O_NOFOLLOW), and keeps it
// open: every later write and the fsync go through that descriptor, never
// through the name, so a name replaced in a shared directory (a symlink
// planted after the probe) redirects nothing. commit() fsyncs it and renames
// it over the destination, after checking that the name still holds this
// file. Until then the destination is untouched.
//
// Signals: while one exists, SIGINT, SIGTERM, SIGHUP and SIGPIPE end the
// process (status 128 + the signal) with one line on stderr that says
// whether the result file was written: before the rename, the temporary
// file is removed ("no result file was written"); once the rename is done,
// the file stays ("the result file F was written"). The line is true
// whichever thread takes the signal (Google Benchmark's, Open MPI's): the
// committing thread blocks the signals for itself across the rename, and a
// handler on another thread waits for the rename's outcome before it
// speaks. A signal the process inherited as ignored (SIGHUP under nohup,
// SIGINT in a background job of a script) stays ignored.
//
// The destination's directory: one the user names must exist. The default
// destination's (default_result_path) is lockstep's to make: with
// make_directory::when_missing it is created here when missing, and removed
// again, if still empty, when no file was committed (a failure, a refusal
// after this point, a signal), so a run that wrote nothing leaves nothing.
enum class make_directory { never, when_missing };

class atomic_result_file {
 public:
  explicit atomic_result_file(std::string destination, make_directory directory = make_directory::never);
  ~atomic_result_file();  // removes the temporary file unless committed
  atomic_result_file(const atomic_result_file&) = delete;  // owns the signal handlers' path and the descriptor
  atomic_result_file& operator=(const atomic_result_file&) = delete;

  // The path through which a tool that writes the file itself reaches the
  // temporary file:
  // /proc/self/fd/N, the open file itself whatever happens to its name
  // (the temporary file's name where /proc is not mounted).
  const std::string& temporary_path() const noexcept { return through_descriptor_; }
  const std::string& destination() const noexcept { return destination_; }
  // Replaces the temporary file's content with `text`.
  void write(std::string_view text);
  // fsyncs the temporary file and renames it over the destination; throws
  // std::runtime_error when that fails or when the temporary file's name no
  // longer holds this file (the temporary file is then removed).
  void commit();

 private:
  std::string destination_;
  std::string temporary_;
  std::string through_descriptor_;
  std::string made_directory_;  // the directory this file created, or empty
  int descriptor_ = -1;
  bool committed_ = false;
};

// check + write + commit in one call: the whole file or nothing.
void write_result_file(const std::string& destination, std::string_view text);

// results/<host>-<UTC timestamp>.json. Nothing is created: the result file
// opened on it with make_directory::when_missing makes the directory, and
// only then.
std::string default_result_path();

}  // namespace lockstep::bench
