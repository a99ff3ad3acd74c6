// The one result writer (bench/results/result_file.hpp) under the signals and
// the name games it promises to survive. Each signal case runs in a child
// process (a GoogleTest death test): the child writes a result file and is
// signalled; the parent checks its exit, its last line and what the
// directory holds afterwards.
#include <signal.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <thread>

#include "bench/results/result_file.hpp"
#include "tests/support/scratch_directory.hpp"

namespace {

namespace fs = std::filesystem;
using lockstep::bench::atomic_result_file;
using lockstep::bench::result_path_error;
using lockstep::testing::scratch_directory;

std::string content_of(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
}

// Sends `signal_number` to the whole process from a thread of its own, as
// a terminal or `kill` does: any thread may take it.
void signal_from_another_thread(int signal_number) {
  std::thread([signal_number] { ::kill(::getpid(), signal_number); }).join();
  // The handler ends the process; give it the time to run.
  for (int nap = 0; nap < 1000; ++nap) ::usleep(1000);
}

// The death tests fork without re-running the test (GoogleTest's "fast"
// style, the default): the child writes into the parent's scratch directory,
// and the process has no other thread when it forks.
class ResultFileSignals : public ::testing::Test {
 protected:
  scratch_directory scratch_{"lockstep-result-file"};
};

// A signal while the file is written: the temporary file goes, an existing
// result stays as it was, and the line says nothing was written.
TEST_F(ResultFileSignals, SigtermBeforeTheRenameLeavesTheOldFileAndNoPartialOne) {
  const std::string path = scratch_.file("r.json");
  write_text(path, "the previous result\n");
  EXPECT_EXIT(
      {
        atomic_result_file file(path);
        file.write("half of a new result");
        signal_from_another_thread(SIGTERM);
      },
      ::testing::ExitedWithCode(128 + SIGTERM), "no result file was written");
  EXPECT_EQ(content_of(path), "the previous result\n");
  EXPECT_EQ(scratch_.entries().size(), 1u) << "a partial file was left behind";
}

// A signal after the rename (the handlers are still installed until the
// object goes): the file is whole and the line says it was written.
TEST_F(ResultFileSignals, SigtermAfterTheRenameSaysTheFileWasWritten) {
  const std::string path = scratch_.file("r.json");
  EXPECT_EXIT(
      {
        atomic_result_file file(path);
        file.write("the whole result\n");
        file.commit();
        signal_from_another_thread(SIGTERM);
      },
      ::testing::ExitedWithCode(128 + SIGTERM), "the result file .*r\\.json was written");
  EXPECT_EQ(content_of(path), "the whole result\n");
  EXPECT_EQ(scratch_.entries().size(), 1u);
}

// nohup: SIGHUP inherited as ignored stays ignored, and the run ends normally
// with its whole file.
TEST_F(ResultFileSignals, AnInheritedIgnoredSighupStaysIgnored) {
  const std::string path = scratch_.file("r.json");
  EXPECT_EXIT(
      {
        ::signal(SIGHUP, SIG_IGN);
        atomic_result_file file(path);
        signal_from_another_thread(SIGHUP);
        file.write("written after the hang-up\n");
        file.commit();
        std::exit(0);
      },
      ::testing::ExitedWithCode(0), "");
  EXPECT_EQ(content_of(path), "written after the hang-up\n");
}

// Not inherited as ignored, SIGHUP ends the process like SIGTERM.
TEST_F(ResultFileSignals, SighupEndsTheWriteWhenNotIgnored) {
  const std::string path = scratch_.file("r.json");
  EXPECT_EXIT(
      {
        ::signal(SIGHUP, SIG_DFL);
        atomic_result_file file(path);
        signal_from_another_thread(SIGHUP);
      },
      ::testing::ExitedWithCode(128 + SIGHUP), "no result file was written");
  EXPECT_TRUE(scratch_.entries().empty());
}

// A symbolic link planted on the temporary file's name after it was created
// redirects nothing: the writes go to the open file, and commit refuses to
// publish the link.
TEST(ResultFileNames, AReplacedTemporaryNameRedirectsNothing) {
  scratch_directory scratch("lockstep-result-file");
  const std::string victim = scratch.file("victim.txt");
  write_text(victim, "somebody else's file\n");
  const std::string path = scratch.file("r.json");
  {
    atomic_result_file file(path);
    const std::string temporary = path + ".partial-" + std::to_string(::getpid());
    ASSERT_TRUE(fs::exists(temporary));
    fs::remove(temporary);
    fs::create_symlink(victim, temporary);
    file.write("the result\n");
    EXPECT_THROW(file.commit(), std::runtime_error);
  }
  EXPECT_EQ(content_of(victim), "somebody else's file\n");
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(fs::is_symlink(path));
}

// A link already on the temporary file's name: the writer refuses to start.
TEST(ResultFileNames, ALinkOnTheTemporaryNameIsRefused) {
  scratch_directory scratch("lockstep-result-file");
  const std::string victim = scratch.file("victim.txt");
  write_text(victim, "somebody else's file\n");
  const std::string path = scratch.file("r.json");
  fs::create_symlink(victim, path + ".partial-" + std::to_string(::getpid()));
  EXPECT_THROW(atomic_result_file file(path), result_path_error);
  EXPECT_EQ(content_of(victim), "somebody else's file\n");
}

// A tool that writes the file by the path it is given (Google Benchmark)
// writes the temporary file, and the commit publishes what it wrote.
TEST(ResultFileNames, AToolWritingThroughTheTemporaryPathIsPublished) {
  scratch_directory scratch("lockstep-result-file");
  const std::string path = scratch.file("r.json");
  {
    atomic_result_file file(path);
    {
      std::ofstream tool(file.temporary_path());
      tool << "{\"benchmarks\": []}\n";
    }
    std::ifstream back(file.temporary_path());
    std::stringstream read;
    read << back.rdbuf();
    EXPECT_EQ(read.str(), "{\"benchmarks\": []}\n");
    file.commit();
  }
  EXPECT_EQ(content_of(path), "{\"benchmarks\": []}\n");
  EXPECT_EQ(scratch.entries().size(), 1u);
}

}  // namespace
