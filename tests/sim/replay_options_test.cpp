// esfleet-replay's command line: flags parsed from an argv into ReplayOptions (--odometry on|off
// into a bool), and validate() naming the flag whose value is wrong.
#include "replay_options.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "app/program.hpp"

namespace esfleet::sim {
namespace {

std::optional<int> parse(ReplayOptions& o, std::vector<std::string> args) {
  app::Program p("esfleet-replay", "replay", "test");
  add_replay_flags(p.cli(), o);
  args.insert(args.begin(), "esfleet-replay");
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  return p.parse(static_cast<int>(argv.size()), argv.data());
}

std::string usage_error(const ReplayOptions& o) {
  try {
    o.validate();
  } catch (const app::UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(ReplayFlags, ParseIntoTheOptions) {
  ReplayOptions o;
  ASSERT_EQ(parse(o, {"--log", "a.clf", "--robot-id", "r1", "--rate", "0", "--first-scan", "20",
                      "--max-scans", "300", "--wait-subscribers", "2"}),
            std::nullopt);
  EXPECT_EQ(o.log, "a.clf");
  EXPECT_EQ(o.robot_id, "r1");
  EXPECT_EQ(o.rate, 0.0);
  EXPECT_EQ(o.first_scan, 20u);
  EXPECT_EQ(o.max_scans, 300u);
  EXPECT_EQ(o.wait_subscribers, 2);
  EXPECT_TRUE(o.odometry);  // default on
  EXPECT_EQ(usage_error(o), "");
}

TEST(ReplayFlags, OdometryIsOnOrOff) {
  ReplayOptions off;
  ASSERT_EQ(parse(off, {"--log", "a", "--robot-id", "r", "--odometry", "off"}), std::nullopt);
  EXPECT_FALSE(off.odometry);
  ReplayOptions bad;
  EXPECT_EQ(parse(bad, {"--log", "a", "--robot-id", "r", "--odometry", "yes"}),
            std::optional<int>(app::kExitUsage));
  ReplayOptions missing;
  EXPECT_EQ(parse(missing, {"--log", "a"}), std::optional<int>(app::kExitUsage));  // --robot-id
}

TEST(ReplayOptionsValidate, NamesTheFlag) {
  ReplayOptions o;
  o.log = "a.clf";
  EXPECT_EQ(usage_error(o), "--robot-id must not be empty");
  o.robot_id = std::string(65, 'r');
  EXPECT_EQ(usage_error(o), "--robot-id: at most 64 characters");
  o.robot_id = "r1";
  o.rate = -1.0;
  EXPECT_EQ(usage_error(o), "--rate must be in [0, 1e6]");
  o.rate = 1.0;
  o.wait_subscribers = -1;
  EXPECT_EQ(usage_error(o), "--wait-subscribers must be >= 0");
  o.wait_subscribers = 1;
  o.domain = 233;
  EXPECT_EQ(usage_error(o), "--domain must be in [0, 232]");
}

}  // namespace
}  // namespace esfleet::sim
