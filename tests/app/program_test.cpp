// The programs' shared prologue: exit codes of the parser and of the run wrapper, --version,
// and the typed parameter flags in --help.

#include "app/program.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "app/param_table.hpp"

namespace esfleet::app {
namespace {

std::optional<int> parse(Program& p, std::vector<std::string> args) {
  args.insert(args.begin(), "prog");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return p.parse(static_cast<int>(argv.size()), argv.data());
}

TEST(Program, ParseErrorsAreUsageErrorsExit2) {
  Program p("esfleet-test", "test", "a test program");
  int n = 0;
  p.cli().add_option("--n", n, "a number");
  EXPECT_EQ(parse(p, {"--n", "x"}), std::optional<int>(kExitUsage));
  Program q("esfleet-test", "test", "a test program");
  EXPECT_EQ(parse(q, {"--no-such-flag"}), std::optional<int>(kExitUsage));
}

TEST(Program, HelpAndVersionExit0AndValidArgumentsGoOn) {
  Program p("esfleet-test", "test", "a test program", "130 stopped by a signal");
  int n = 0;
  p.cli().add_option("--n", n, "a number");
  testing::internal::CaptureStdout();
  EXPECT_EQ(parse(p, {"--version"}), std::optional<int>(kExitOk));
  EXPECT_EQ(testing::internal::GetCapturedStdout(),
            std::string("esfleet-test ") + version() + "\n");
  Program h("esfleet-test", "test", "a test program", "130 stopped by a signal");
  testing::internal::CaptureStdout();
  EXPECT_EQ(parse(h, {"--help"}), std::optional<int>(kExitOk));
  const std::string help = testing::internal::GetCapturedStdout();
  EXPECT_NE(help.find("Exit codes: 0 done, 1 failure while running, 2 bad usage or bad input, "
                      "130 stopped by a signal."),
            std::string::npos)
      << help;
  EXPECT_EQ(parse(p, {"--n", "7"}), std::nullopt);
  EXPECT_EQ(n, 7);
}

TEST(Program, RunMapsExceptionsToExitCodes) {
  const Program p("esfleet-test", "test", "a test program");
  EXPECT_EQ(p.run([] { return 130; }), 130);
  EXPECT_EQ(p.run([]() -> int { throw UsageError("--log x: no such file"); }), kExitUsage);
  EXPECT_EQ(p.run([]() -> int { throw std::invalid_argument("mu must be > 0"); }), kExitUsage);
  EXPECT_EQ(p.run([]() -> int { throw std::runtime_error("disk full"); }), kExitFailure);
}

TEST(Program, ASetUpStepThatFailsIsAUsageErrorNamingTheStep) {
  try {
    setup_step("DDS", [] { throw std::runtime_error("domain 300 out of range"); });
    FAIL() << "no exception";
  } catch (const UsageError& e) {
    EXPECT_STREQ(e.what(), "DDS: domain 300 out of range");
  }
  EXPECT_NO_THROW(setup_step("fine", [] {}));
  EXPECT_EQ(name_flag("--world", "w.yaml", "w.yaml: field 'resolution' missing"),
            "--world w.yaml: field 'resolution' missing");
  EXPECT_EQ(name_flag("--out", "o", "Permission denied"), "--out o: Permission denied");
}

TEST(ParamTable, HelpShowsEachValueType) {
  double d = 0.5;
  int i = 3;
  std::uint64_t u = 4;
  bool b = true;
  ParamTable t;
  t.add_double("alpha_xy", &d, "a length");
  t.add_int("mu", &i, "parents");
  t.add_u64("budget", &u, "scans");
  t.add_switch("refine", &b, "polish");
  CLI::App app;
  t.bind(app);
  const std::string help = app.help();
  EXPECT_NE(help.find("--alpha-xy FLOAT=0.5"), std::string::npos) << help;
  EXPECT_NE(help.find("--mu INT=3"), std::string::npos) << help;
  EXPECT_NE(help.find("--budget UINT=4"), std::string::npos) << help;
  EXPECT_NE(help.find("--refine on|off=on"), std::string::npos) << help;
  EXPECT_EQ(help.find("TEXT="), std::string::npos) << help;
}

TEST(ParamTable, DescribesWhatDiffersFromTheDefaults) {
  double d = 0.5;
  int i = 3;
  ParamTable t;
  t.add_double("alpha_xy", &d, "a length");
  t.add_int("mu", &i, "parents");
  CLI::App app;
  t.bind(app);
  EXPECT_EQ(t.describe_changes(), "all defaults");
  const char* argv[] = {"x", "--mu", "50"};
  app.parse(3, const_cast<char**>(argv));
  t.apply();
  EXPECT_EQ(t.describe_changes(), "1 changed: mu = 50");
  d = 0.25;  // e.g. --paper replaced the configuration
  EXPECT_EQ(t.describe_changes(), "2 changed: alpha_xy = 0.25, mu = 50");
}

TEST(ParamTable, KnowsWhichParametersTheFileOrAFlagGaveAndSetsByName) {
  double d = 0.5;
  int i = 3;
  bool b = false;
  ParamTable t;
  t.add_double("alpha_xy", &d, "a length");
  t.add_int("mu", &i, "parents");
  t.add_switch("penalty", &b, "a switch");
  const std::filesystem::path yaml =
      std::filesystem::path(::testing::TempDir()) / ("params-given-" + std::to_string(::getpid()));
  std::ofstream(yaml) << "alpha_xy: 0.5\n";  // given, even though it is the default
  CLI::App app;
  t.bind(app);
  const std::string path = yaml.string();
  const char* argv[] = {"x", "--config", path.c_str(), "--mu", "3"};
  app.parse(5, const_cast<char**>(argv));
  t.apply();
  std::filesystem::remove(yaml);
  EXPECT_TRUE(t.given("alpha_xy"));
  EXPECT_TRUE(t.given("mu"));
  EXPECT_FALSE(t.given("penalty"));
  EXPECT_FALSE(t.given("no_such"));
  t.set("penalty", "on");
  EXPECT_TRUE(b);
  EXPECT_THROW(t.set("mu", "many"), std::invalid_argument);
  EXPECT_EQ(i, 3);
  EXPECT_THROW(t.set("no_such", "1"), std::invalid_argument);
}

}  // namespace
}  // namespace esfleet::app
