// `lockstep verify` as a user runs it: exit status, what it prints, and the
// CSV and JSON it writes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "kernels/normal_modes.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/scratch_directory.hpp"

namespace {

using lockstep::testing::command_result;
using lockstep::testing::count_lines;
using lockstep::testing::run_command;

command_result verify(std::vector<std::string> arguments) {
  arguments.insert(arguments.begin(), {LOCKSTEP_BINARY, "verify"});
  return run_command(arguments);
}


std::string slurp(const std::string& path) {
  std::ifstream input(path);
  std::stringstream text;
  text << input.rdbuf();
  return text.str();
}

TEST(VerifyCli, PapersCasePassesAndShowsRootsBesideThePapers) {
  const command_result result = verify({});
  EXPECT_EQ(result.exit_status, 0) << result.out << result.err;
  EXPECT_EQ(result.err, "");
  EXPECT_NE(result.out.find("±51.4855j"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("±19.6657j"), std::string::npos);
  EXPECT_NE(result.out.find("±51.47j"), std::string::npos);
  EXPECT_NE(result.out.find("±19.66j"), std::string::npos);
  EXPECT_NE(result.out.find("C/m = 1011.9"), std::string::npos) << "the C/m the paper's roots imply";
  EXPECT_NE(result.out.find("observed order 4.0"), std::string::npos);
  EXPECT_NE(result.out.find("dopri5"), std::string::npos);
  EXPECT_NE(result.out.find("Energy"), std::string::npos);
  EXPECT_EQ(result.out.find("FAIL"), std::string::npos);
}

TEST(VerifyCli, BadInputIsExitTwoWithOneLine) {
  const std::vector<std::vector<std::string>> bad_inputs = {
      {"--dt", "0"},     {"--dt", "-0.001"}, {"--dt", "nan"},   {"--dt", "inf"},     {"--t-end", "nan"},
      {"--t-end", "0"},  {"--m1", "0"},      {"--m2", "-0.02"}, {"--c1", "0"},       {"--c2", "-20"},
      {"--m1", "nan"},   {"--c2", "inf"},    {"--m2", "-inf"},  {"--bogus"},         {"--dt", "abc"},
      {"--dt", "0.3"},   {"--dt", "2"},      {"--t-end", "1e9"}, {"--csv"},           {"extra"},
      {"--masses", "0"}, {"--masses", "513"}, {"--masses", "x"}, {"--masses", "3", "--m1", "0.05"},
      {"--masses", "100", "--dt", "10us"}};
  for (const auto& arguments : bad_inputs) {
    const command_result result = verify(arguments);
    std::string shown;
    for (const auto& argument : arguments) shown += argument + " ";
    EXPECT_EQ(result.exit_status, 2) << shown << result.out << result.err;
    EXPECT_EQ(count_lines(result.err), 1) << shown << result.err;
    EXPECT_EQ(result.out, "") << shown;
  }
  // The message names what is wrong.
  EXPECT_NE(verify({"--dt", "0"}).err.find("--dt"), std::string::npos);
  EXPECT_NE(verify({"--m2", "-1"}).err.find("--m2"), std::string::npos);
  EXPECT_NE(verify({"--c1", "nan"}).err.find("--c1"), std::string::npos);
}

TEST(VerifyCli, UnwritableOutputIsExitTwo) {
  for (const char* flag : {"--csv", "--out"}) {
    const command_result result = verify({flag, "/nonexistent-lockstep-dir/out"});
    EXPECT_EQ(result.exit_status, 2) << flag;
    EXPECT_EQ(count_lines(result.err), 1) << result.err;
    EXPECT_NE(result.err.find("/nonexistent-lockstep-dir/out"), std::string::npos);
  }
}

TEST(VerifyCli, ErrorsOutsideTheBoundsAreExitOne) {
  const command_result result = verify({"--dt", "50ms"});  // w_fast h = 2.6: RK4 far from fourth order
  EXPECT_EQ(result.exit_status, 1) << result.out << result.err;
  EXPECT_NE(result.out.find("FAIL"), std::string::npos);
}

TEST(VerifyCli, CsvHoldsTheTrajectory) {
  const lockstep::testing::scratch_directory directory("lockstep-verify");
  const std::string path = directory.file("trajectory.csv");
  const command_result result = verify({"--dt", "2ms", "--t-end", "500ms", "--csv", path});
  ASSERT_EQ(result.exit_status, 0) << result.out << result.err;
  std::istringstream csv(slurp(path));
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(line, "t,x1,x2,exact_x1,exact_x2");
  const lockstep::kernels::normal_mode_solution exact =
      lockstep::kernels::normal_mode_solution::two_mass(lockstep::kernels::two_mass_params{});
  int rows = 0;
  while (std::getline(csv, line)) {
    double time = 0, x1 = 0, x2 = 0, exact_x1 = 0, exact_x2 = 0;
    char comma1 = 0, comma2 = 0, comma3 = 0, comma4 = 0;
    std::istringstream row(line);
    ASSERT_TRUE(row >> time >> comma1 >> x1 >> comma2 >> x2 >> comma3 >> exact_x1 >> comma4 >> exact_x2) << line;
    ASSERT_EQ(std::string({comma1, comma2, comma3, comma4}), ",,,,");
    EXPECT_NEAR(time, rows * 0.002, 1e-12);
    const std::vector<double> state = exact.state_at(time);
    // The file's exact columns are the analytic solution (to the digits written).
    EXPECT_NEAR(exact_x1, state[0], 1e-12) << "t = " << time;
    EXPECT_NEAR(exact_x2, state[1], 1e-12) << "t = " << time;
    // RK4 at h = 2 ms over 0.5 s: the bound from h is about 1.4e-4 m.
    EXPECT_NEAR(x1, state[0], 2e-4) << "t = " << time;
    EXPECT_NEAR(x2, state[1], 2e-4) << "t = " << time;
    if (rows == 0) {
      EXPECT_EQ(x1, 2.0);
      EXPECT_EQ(x2, -3.0);
    }
    ++rows;
  }
  EXPECT_EQ(rows, 251);
  EXPECT_EQ(directory.entries(), std::vector<std::string>{"trajectory.csv"}) << "no temporary file left behind";
}

TEST(VerifyCli, JsonHoldsTheFigures) {
  const lockstep::testing::scratch_directory directory("lockstep-verify");
  const std::string path = directory.file("verify.json");
  const command_result result = verify({"--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.out << result.err;
  const nlohmann::json json = nlohmann::json::parse(slurp(path));
  EXPECT_EQ(json.at("kind"), "verify");
  EXPECT_EQ(json.at("lockstep_schema"), 2);
  EXPECT_TRUE(json.at("passed").get<bool>());
  EXPECT_TRUE(json.at("parameters").at("papers_case").get<bool>());
  EXPECT_DOUBLE_EQ(json.at("parameters").at("m1").get<double>(), 0.02);
  EXPECT_DOUBLE_EQ(json.at("parameters").at("c2").get<double>(), 20.25);
  const auto& roots = json.at("roots");
  EXPECT_NEAR(roots.at("computed_rad_s").at("fast").get<double>(), 51.49, 0.005);
  EXPECT_NEAR(roots.at("computed_rad_s").at("slow").get<double>(), 19.67, 0.005);
  EXPECT_EQ(roots.at("paper_rad_s").at("fast").get<double>(), 51.47);
  EXPECT_EQ(roots.at("paper_rad_s").at("slow").get<double>(), 19.66);
  EXPECT_NEAR(roots.at("paper_implied_c_over_m").get<double>(), 1011.9, 0.05);
  EXPECT_LE(std::abs(roots.at("relative_difference_vs_paper").at("fast").get<double>()), 1e-3);
  const auto& ladder = json.at("ladder");
  ASSERT_EQ(ladder.size(), 4U);
  for (const auto& rung : ladder) EXPECT_LE(rung.at("max_error").get<double>(), rung.at("bound").get<double>());
  EXPECT_DOUBLE_EQ(ladder[1].at("dt").get<double>(), ladder[0].at("dt").get<double>() / 2);
  const double order = json.at("observed_order").get<double>();
  EXPECT_GE(order, 3.9);
  EXPECT_LE(order, 4.1);
  EXPECT_LE(json.at("energy").at("max_relative_drift").get<double>(), json.at("energy").at("bound").get<double>());
  EXPECT_LE(json.at("dopri5").at("max_difference_vs_rk4").get<double>(),
            json.at("dopri5").at("difference_bound").get<double>());
  EXPECT_GT(json.at("dopri5").at("steps").get<int>(), 0);
  for (const auto& check : json.at("checks")) {
    EXPECT_TRUE(check.at("passed").get<bool>()) << check.dump();
    EXPECT_FALSE(check.at("basis").get<std::string>().empty());
  }
  EXPECT_EQ(directory.entries(), std::vector<std::string>{"verify.json"}) << "no temporary file left behind";
}

TEST(VerifyCli, OtherParametersAreUsed) {
  const lockstep::testing::scratch_directory directory("lockstep-verify");
  const std::string path = directory.file("verify.json");
  const command_result result =
      verify({"--m1", "0.05", "--m2", "0.01", "--c1", "3", "--c2", "70", "--dt", "500us", "--t-end", "500ms", "--out", path});
  ASSERT_EQ(result.exit_status, 0) << result.out << result.err;
  EXPECT_NE(result.out.find("not the paper's case"), std::string::npos);
  const nlohmann::json json = nlohmann::json::parse(slurp(path));
  EXPECT_FALSE(json.at("parameters").at("papers_case").get<bool>());
  EXPECT_DOUBLE_EQ(json.at("parameters").at("c2").get<double>(), 70.0);
  const lockstep::kernels::two_mass_frequencies expected = lockstep::kernels::two_mass_angular_frequencies(
      {.m1 = 0.05, .m2 = 0.01, .c1 = 3.0, .c2 = 70.0});
  EXPECT_DOUBLE_EQ(json.at("roots").at("computed_rad_s").at("fast").get<double>(), expected.fast);
}

// --masses S: the uniform chain, checked the same way, without the paper's
// printed roots (they belong to its two masses).
TEST(VerifyCli, MassesChecksTheUniformChain) {
  const lockstep::testing::scratch_directory directory("lockstep-verify");
  const std::string json_path = directory.file("verify.json");
  const std::string csv_path = directory.file("trajectory.csv");
  const command_result result = verify({"--masses", "8", "--out", json_path, "--csv", csv_path});
  ASSERT_EQ(result.exit_status, 0) << result.out << result.err;
  EXPECT_EQ(result.err, "");
  EXPECT_NE(result.out.find("lockstep verify: a chain of 8 masses (16 equations)"), std::string::npos) << result.out;
  EXPECT_NE(result.out.find("verify: a chain of 8 masses (16 equations): all"), std::string::npos) << result.out;
  EXPECT_EQ(result.out.find("±51.47j"), std::string::npos) << "the paper's roots are its two masses'";
  EXPECT_NE(result.out.find("observed order 4.0"), std::string::npos);
  EXPECT_EQ(result.out.find("FAIL"), std::string::npos);

  const nlohmann::json json = nlohmann::json::parse(slurp(json_path));
  EXPECT_EQ(json.at("model").at("name"), "chain8");
  EXPECT_EQ(json.at("model").at("masses"), 8);
  EXPECT_EQ(json.at("model").at("equations"), 16);
  EXPECT_TRUE(json.at("passed").get<bool>());
  EXPECT_FALSE(json.at("parameters").at("papers_case").get<bool>());
  const auto& roots = json.at("roots");
  ASSERT_EQ(roots.at("closed_form_rad_s").size(), 8U);
  ASSERT_EQ(roots.at("eigen_rad_s").size(), 8U);
  EXPECT_FALSE(roots.contains("paper_rad_s"));
  EXPECT_LE(roots.at("closed_form_vs_eigen_relative").get<double>(), 1e-9);
  for (const auto& check : json.at("checks")) {
    EXPECT_TRUE(check.at("passed").get<bool>()) << check.dump();
    EXPECT_EQ(check.at("name").get<std::string>().find("paper"), std::string::npos) << check.dump();
  }

  // Every mass's position, starting from the uniform chain's 2, -3, 2, ... m.
  std::istringstream csv(slurp(csv_path));
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(line,
            "t,x1,x2,x3,x4,x5,x6,x7,x8,exact_x1,exact_x2,exact_x3,exact_x4,exact_x5,exact_x6,exact_x7,exact_x8");
  ASSERT_TRUE(std::getline(csv, line));
  // RK4 starts from the initial state itself; the exact solution's sum of
  // modes gives it back to rounding.
  EXPECT_EQ(line.rfind("0,2,-3,2,-3,2,-3,2,-3,", 0), 0u) << line;
  std::istringstream row(line.substr(std::string("0,2,-3,2,-3,2,-3,2,-3,").size()));
  for (int mass = 0; mass < 8; ++mass) {
    double exact = 0;
    char comma = ',';
    ASSERT_TRUE(row >> exact) << line;
    EXPECT_NEAR(exact, mass % 2 == 0 ? 2.0 : -3.0, 1e-12) << line;
    if (mass < 7) {
      ASSERT_TRUE(row >> comma && comma == ',') << line;
    }
  }
}

TEST(VerifyCli, HelpNamesTheFlags) {
  const command_result result = run_command({LOCKSTEP_BINARY, "help", "verify"});
  EXPECT_EQ(result.exit_status, 0);
  for (const char* flag : {"--m1", "--m2", "--c1", "--c2", "--masses", "--dt", "--t-end", "--csv", "--out"}) {
    EXPECT_NE(result.out.find(flag), std::string::npos) << flag;
  }
}

}  // namespace
