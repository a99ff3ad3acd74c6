// `lockstep compare` and `lockstep report` run through the lockstep binary as a
// user would: arguments pass through to the Python tools, and their exit
// statuses (0, 1 for a regression beyond --fail-above, 2 for bad input) come back.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/support/run_command.hpp"

namespace {

using lockstep::testing::count_lines;
using lockstep::testing::run_command;

std::string fixture(const std::string& name) {
  return std::string(LOCKSTEP_SOURCE_DIR) + "/reports/tests/fixtures/" + name;
}

std::filesystem::path fresh_directory(const std::string& name) {
  auto directory = std::filesystem::temp_directory_path() / ("lockstep-reports-cli-" + name);
  std::filesystem::remove_all(directory);
  std::filesystem::create_directories(directory);
  return directory;
}

std::string slurp(const std::filesystem::path& path) {
  std::ifstream stream(path, std::ios::binary);
  std::ostringstream text;
  text << stream.rdbuf();
  return text.str();
}

TEST(ReportsCli, CompareShowsTheForcedRegressionAndPassesFailAboveThrough) {
  const auto result = run_command({LOCKSTEP_BINARY, "compare", fixture("machine_a.json"),
                                   fixture("machine_a_rerun.json"), "--fail-above", "10"});
  EXPECT_EQ(result.exit_status, 1) << result.err;
  EXPECT_NE(result.out.find("geometric mean of B/A over the 36 matched pairs"), std::string::npos);
  EXPECT_NE(result.err.find("rk4/sync:futex_spin/layout:packed/pin:compact/threads:4"), std::string::npos);
}

TEST(ReportsCli, OptionsBeforeTheFilesPassThroughToo) {
  // The q-values and their alpha are --all's (the default text leaves them out).
  const auto result = run_command({LOCKSTEP_BINARY, "compare", "--fail-above", "50", "--alpha", "0.01", "--all",
                                   fixture("machine_a.json"), fixture("machine_a_rerun.json")});
  EXPECT_EQ(result.exit_status, 0) << result.err;
  EXPECT_NE(result.out.find("alpha 0.01"), std::string::npos);
}

TEST(ReportsCli, TruncatedFileIsOneLineAndExit2) {
  const auto result = run_command({LOCKSTEP_BINARY, "compare", fixture("machine_a.json"), fixture("truncated.json")});
  EXPECT_EQ(result.exit_status, 2);
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("truncated.json"), std::string::npos);
  EXPECT_NE(result.err.find("truncated"), std::string::npos);
}

TEST(ReportsCli, HelpIsThePythonToolsHelp) {
  const auto result = run_command({LOCKSTEP_BINARY, "compare", "--help"});
  EXPECT_EQ(result.exit_status, 0);
  EXPECT_NE(result.out.find("--fail-above"), std::string::npos);
}

TEST(ReportsCli, MissingReportsDirectoryIsOneLineAndExit2) {
  ::setenv("LOCKSTEP_REPORTS_DIR", "/nonexistent/lockstep-reports", 1);
  const auto result = run_command({LOCKSTEP_BINARY, "compare", fixture("machine_a.json"), fixture("machine_b.json")});
  ::unsetenv("LOCKSTEP_REPORTS_DIR");
  EXPECT_EQ(result.exit_status, 2);
  EXPECT_EQ(count_lines(result.err), 1) << result.err;
  EXPECT_NE(result.err.find("LOCKSTEP_REPORTS_DIR"), std::string::npos);
}

TEST(ReportsCli, ReportWritesHtmlAndMarkdown) {
  const auto out = fresh_directory("report");
  const auto result = run_command({LOCKSTEP_BINARY, "report", fixture("machine_a.json"), fixture("c2c_b.json"),
                                   fixture("delay_a.json"), fixture("verify_a.csv"), "--out", out.string()});
  ASSERT_EQ(result.exit_status, 0) << result.err;
  const std::string html = slurp(out / "report.html");
  const std::string markdown = slurp(out / "report.md");
  EXPECT_NE(html.find("<svg"), std::string::npos);
  EXPECT_EQ(html.find("src=\"http"), std::string::npos);  // self-contained: nothing fetched
  EXPECT_EQ(html.find("href=\"http"), std::string::npos);
  EXPECT_NE(markdown.find("Figure 5"), std::string::npos);
  std::filesystem::remove_all(out);
}

}  // namespace
