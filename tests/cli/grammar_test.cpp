// One command-line grammar (bench/cli/options.hpp): the readers of sizes and
// percentages, the typing-mistake rule, and the binary's help as a user reads
// it (`lockstep help COMMAND` is `lockstep COMMAND --help`, old option names
// are marked old, the top-level help says what compare computes). The bad
// inputs, suggestions among them, are tests/cli/bad_input_test.cpp's.
#include <gtest/gtest.h>

#include <cctype>
#include <cstdint>
#include <optional>
#include <utility>
#include <string>
#include <vector>

#include "bench/cli/command.hpp"
#include "bench/cli/options.hpp"
#include "tests/support/run_command.hpp"

namespace {

using lockstep::cli::usage_error;
using lockstep::testing::command_result;
using lockstep::testing::run_command;

constexpr std::uint64_t kKiB = 1024;

TEST(SizeBytes, BinaryUnitsAndPlainBytes) {
  using lockstep::cli::parse_size_bytes;
  EXPECT_EQ(parse_size_bytes("256KiB", "--bytes"), 256 * kKiB);
  EXPECT_EQ(parse_size_bytes("4MiB", "--bytes"), 4 * kKiB * kKiB);
  EXPECT_EQ(parse_size_bytes("1GiB", "--bytes"), kKiB * kKiB * kKiB);
  EXPECT_EQ(parse_size_bytes("64B", "--bytes"), 64u);
  EXPECT_EQ(parse_size_bytes("65536", "--bytes"), 65536u);
  EXPECT_EQ(parse_size_bytes("0.5KiB", "--bytes"), 512u);
  EXPECT_EQ(parse_size_bytes("1.5MiB", "--bytes"), 1536 * kKiB);
}

TEST(SizeBytes, RefusesAmbiguousUnitsAndPartBytes) {
  using lockstep::cli::parse_size_bytes;
  const std::string too_many_digits(400, '9');
  for (const std::string& text : {std::string("256KB"), std::string("256kB"), std::string("4MB"), std::string("1GB"),
                                  std::string("256K"), std::string("4M"), std::string(), std::string("KiB"),
                                  std::string("-4KiB"), std::string("1e3"), std::string("256 KiB"),
                                  std::string("256kib"), std::string("1.3B"), std::string("0.1KiB"),
                                  std::string("1..2KiB"), too_many_digits + "KiB"})
    EXPECT_THROW(parse_size_bytes(text, "--bytes"), usage_error) << text;
  try {
    parse_size_bytes("256KB", "--bytes");
  } catch (const usage_error& e) {
    EXPECT_NE(std::string(e.what()).find("256KiB"), std::string::npos) << e.what();  // the hint
  }
  EXPECT_THROW(parse_size_bytes("8", "--bytes", 64, 1024), usage_error);
  EXPECT_THROW(parse_size_bytes("2KiB", "--bytes", 64, 1024), usage_error);
  EXPECT_EQ(parse_size_bytes("1KiB", "--bytes", 64, 1024), 1024u);
}

TEST(SizeBytes, ListsTakeUnitsAndDropRepeats) {
  EXPECT_EQ(lockstep::cli::parse_size_list("8,64,1KiB,64B", "--strides", 8, 4096),
            (std::vector<std::uint64_t>{8, 64, 1024}));
  EXPECT_THROW(lockstep::cli::parse_size_list("8,,64", "--strides", 8, 4096), usage_error);
}

TEST(Percent, SignAndSpacesOptional) {
  using lockstep::cli::parse_percent;
  EXPECT_EQ(parse_percent("5", "--noise"), 5.0);
  EXPECT_EQ(parse_percent("5%", "--noise"), 5.0);
  EXPECT_EQ(parse_percent("0.5 %", "--noise"), 0.5);
  EXPECT_EQ(parse_percent(" 7 % ", "--noise"), 7.0);
  EXPECT_EQ(parse_percent("0", "--noise"), 0.0);
  EXPECT_EQ(parse_percent("100%", "--noise"), 100.0);
  const std::string too_many_digits(400, '9');
  for (const std::string& text : {std::string(), std::string("%"), std::string("abc"), std::string("5%%"),
                                  std::string("-1"), std::string("150"), std::string("100.5%"), std::string("5 5"),
                                  std::string("1e1"), std::string("inf"), std::string("nan"), std::string("5 percent"),
                                  too_many_digits})
    EXPECT_THROW(parse_percent(text, "--noise"), usage_error) << text;
}

// The options as a command declares them: what the user typed, stored.
// (CLI11 takes a vector of arguments last first.)
TEST(Options, NoiseStoresThePercentage) {
  for (const auto& [text, expected] : std::vector<std::pair<std::string, double>>{
           {"5", 5.0}, {"5%", 5.0}, {"0.5 %", 0.5}, {"100", 100.0}}) {
    CLI::App command;
    double percent = 5.0;
    lockstep::cli::add_noise_option(command, percent, "what it decides");
    std::vector<std::string> arguments{text, "--noise"};
    command.parse(arguments);
    EXPECT_EQ(percent, expected) << text;
  }
  CLI::App command;
  double percent = 5.0;
  lockstep::cli::add_noise_option(command, percent, "what it decides");
  std::vector<std::string> arguments{"101%", "--noise"};
  EXPECT_THROW(command.parse(arguments), usage_error);
}

TEST(Options, RepetitionsTakesItsOldName) {
  for (const std::string name : {"--repetitions", "--repeats"}) {
    CLI::App command;
    int repetitions = 9;
    lockstep::cli::add_repetitions_option(command, repetitions, 1000, "one sweep", "--repeats");
    std::vector<std::string> arguments{"3", name};
    command.parse(arguments);
    EXPECT_EQ(repetitions, 3) << name;
  }
}

TEST(Typos, EditDistanceCountsSwapsAsOne) {
  using lockstep::cli::edit_distance;
  EXPECT_EQ(edit_distance("run", "run"), 0u);
  EXPECT_EQ(edit_distance("runn", "run"), 1u);
  EXPECT_EQ(edit_distance("quik", "quick"), 1u);
  EXPECT_EQ(edit_distance("dleay", "delay"), 1u);  // neighbours swapped
  EXPECT_EQ(edit_distance("", "abc"), 3u);
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
}

TEST(Typos, NearestNameOnlyWhenNear) {
  using lockstep::cli::nearest_name;
  const std::vector<std::string> commands{"run", "verify", "c2c", "delay", "falseshare", "migrate", "list", "help"};
  EXPECT_EQ(nearest_name("runn", commands), "run");
  EXPECT_EQ(nearest_name("dleay", commands), "delay");
  EXPECT_EQ(nearest_name("falshare", commands), "falseshare");
  EXPECT_EQ(nearest_name("fals", commands), "falseshare");  // the one name it begins
  EXPECT_EQ(nearest_name("xyzzy", commands), std::nullopt);
  EXPECT_EQ(nearest_name("benchmark", commands), std::nullopt);
  EXPECT_EQ(nearest_name("rep", std::vector<std::string>{"repetitions", "repeats"}), std::nullopt);  // two begin
}

const std::vector<std::string> kCommands{"run",     "verify", "c2c",  "delay", "falseshare", "migrate", "mpi",
                                         "topology", "list",  "compare", "report"};

// `lockstep help COMMAND` prints what `lockstep COMMAND --help` prints, all of
// it: the options, not a usage line alone.
TEST(Help, HelpCommandIsTheCommandsOwnHelp) {
  for (const std::string& command : kCommands) {
    const command_result help = run_command({LOCKSTEP_BINARY, "help", command});
    const command_result flag = run_command({LOCKSTEP_BINARY, command, "--help"});
    EXPECT_EQ(help.exit_status, 0) << command << "\n" << help.err;
    EXPECT_EQ(flag.exit_status, 0) << command << "\n" << flag.err;
    EXPECT_EQ(help.out, flag.out) << command;
    std::string lower = help.out;
    for (char& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    EXPECT_NE(lower.find("options:"), std::string::npos) << command << ": no options in\n" << help.out;
  }
}

// `lockstep help` alone is the overview, `lockstep --help`: every command, not
// the help of `help`.
TEST(Help, HelpAloneIsTheOverview) {
  const command_result help = run_command({LOCKSTEP_BINARY, "help"});
  const command_result flag = run_command({LOCKSTEP_BINARY, "--help"});
  EXPECT_EQ(help.exit_status, 0) << help.err;
  EXPECT_EQ(help.out, flag.out);
  for (const std::string& command : kCommands) EXPECT_NE(help.out.find(command), std::string::npos) << command;
}

TEST(Help, OldNamesAreMarkedOld) {
  for (const auto& [command, old_name] : std::vector<std::pair<std::string, std::string>>{
           {"falseshare", "--repeats"}, {"migrate", "--repeats"}, {"mpi", "--rounds"}}) {
    const command_result help = run_command({LOCKSTEP_BINARY, "help", command});
    EXPECT_NE(help.out.find("--repetitions"), std::string::npos) << command;
    EXPECT_NE(help.out.find(old_name + " is the old name"), std::string::npos) << command << "\n" << help.out;
  }
}

// --masses says what each command splits the model among: threads in run and
// delay, ranks in mpi, nothing in verify (which has neither).
TEST(Help, MassesSpeaksOfWhatTheCommandSplits) {
  for (const auto& [command, member] : std::vector<std::pair<std::string, std::string>>{
           {"run", "thread"}, {"delay", "thread"}, {"mpi", "rank"}, {"verify", ""}}) {
    const command_result help = run_command({LOCKSTEP_BINARY, command, "--help"});
    const auto at = help.out.find("\n  --masses S ");  // the option, not a mention in the description
    ASSERT_NE(at, std::string::npos) << command << "\n" << help.out;
    const std::string line = help.out.substr(at + 1, help.out.find('\n', at + 1) - at - 1);
    for (const std::string word : {"thread", "rank"}) {
      if (word == member)
        EXPECT_NE(line.find(word + "s (default: "), std::string::npos) << command << ": " << line;
      else
        EXPECT_EQ(line.find(word), std::string::npos) << command << ": " << line;
    }
  }
}

TEST(Help, TopLevelSaysWhatCompareComputes) {
  const command_result help = run_command({LOCKSTEP_BINARY, "--help"});
  EXPECT_EQ(help.exit_status, 0);
  EXPECT_NE(help.out.find("Benjamini-Hochberg"), std::string::npos) << help.out;
  EXPECT_EQ(help.out.find("Holm"), std::string::npos) << help.out;  // compare.py does not use it
  for (const std::string& command : kCommands) EXPECT_NE(help.out.find(command), std::string::npos) << command;
}

}  // namespace
