// esfleet-sim's command line: flags parsed from an argv into SimOptions, and validate() naming
// the flag whose value is wrong.
#include "sim_options.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "app/program.hpp"

namespace esfleet::sim {
namespace {

std::optional<int> parse(SimOptions& o, std::vector<std::string> args) {
  app::Program p("esfleet-sim", "sim", "test");
  add_sim_flags(p.cli(), o);
  args.insert(args.begin(), "esfleet-sim");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return p.parse(static_cast<int>(argv.size()), argv.data());
}

/// validate()'s message, or "" when it passes.
std::string usage_error(const SimOptions& o) {
  try {
    o.validate();
  } catch (const app::UsageError& e) {
    return e.what();
  }
  return "";
}

SimOptions valid() {
  SimOptions o;
  o.world = "w.yaml";
  return o;
}

TEST(SimFlags, ParseIntoTheOptions) {
  SimOptions o;
  ASSERT_EQ(
      parse(o, {"--world", "w.yaml", "--robots", "3", "--beams", "361", "--odom-noise-xy", "0.05",
                "--domain", "12", "--offline", "--out-log", "logs", "--duration", "60"}),
      std::nullopt);
  EXPECT_EQ(o.world, "w.yaml");
  EXPECT_EQ(o.fleet.robots, 3);
  EXPECT_EQ(o.fleet.laser.beams, 361);
  EXPECT_DOUBLE_EQ(o.fleet.odometry.noise_xy, 0.05);
  EXPECT_EQ(o.domain, 12);
  EXPECT_TRUE(o.offline);
  EXPECT_EQ(o.out_log, "logs");
  EXPECT_DOUBLE_EQ(o.duration, 60.0);
  EXPECT_EQ(usage_error(o), "");
}

TEST(SimFlags, WorldIsRequired) {
  SimOptions o;
  EXPECT_EQ(parse(o, {"--robots", "2"}), std::optional<int>(app::kExitUsage));
}

TEST(SimFlags, StartStampGivenOrTheWallClock) {
  SimOptions given;
  ASSERT_EQ(parse(given, {"--world", "w.yaml", "--start-stamp", "1000.5"}), std::nullopt);
  EXPECT_DOUBLE_EQ(given.fleet_config().start_stamp, 1000.5);
  SimOptions unset;
  ASSERT_EQ(parse(unset, {"--world", "w.yaml"}), std::nullopt);
  const double stamp = unset.fleet_config().start_stamp;
  EXPECT_GT(stamp, 1.6e9);  // the wall clock (after 2020), whole seconds
  EXPECT_EQ(stamp, std::floor(stamp));
}

TEST(SimOptionsValidate, NamesTheFlag) {
  SimOptions o = valid();
  o.start_stamp = -1.0;  // given and negative: not the wall clock
  EXPECT_EQ(usage_error(o), "--start-stamp must be >= 0");
  o = valid();
  o.fleet.laser.beams = 1;  // the fleet's own check, as a UsageError
  EXPECT_NE(usage_error(o).find("--beams"), std::string::npos) << usage_error(o);
  o = valid();
  o.offline = true;
  EXPECT_EQ(usage_error(o), "--offline needs --out-log DIR");
  o.out_log = "logs";
  EXPECT_EQ(usage_error(o), "--offline needs --duration > 0");
  o = valid();
  o.wait_timeout = -1.0;
  EXPECT_EQ(usage_error(o), "--wait-timeout must be >= 0");
  o = valid();
  o.duration = 2e7;
  EXPECT_EQ(usage_error(o), "--duration must be in [0, 1e7]");
}

}  // namespace
}  // namespace esfleet::sim
