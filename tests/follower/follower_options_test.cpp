// esfleet-follower's command line: the contributed-scan flags (--contribute and its limits,
// the test aid --contribute-pose-offset), parsed and validated before any DDS participant.

#include "follower_options.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "options_test_harness.hpp"

namespace esfleet::follower {
namespace {

using esfleet::testing::contains;

/// Parses `args` like esfleet-follower's main() and finishes the options. Returns the error
/// message ("" when the options are valid).
std::string options_error(std::vector<std::string> args, FollowerOptions* out = nullptr) {
  return esfleet::testing::options_error("esfleet-follower", "follower", std::move(args),
                                         add_follower_flags, finish_follower_options, out);
}

TEST(FollowerOptions, ContributionIsOffByDefaultWithTheDocumentedLimits) {
  FollowerOptions o;
  ASSERT_EQ(options_error({"--log", "x.clf"}, &o), "");
  EXPECT_FALSE(o.contribute.enabled);
  EXPECT_EQ(o.contribute.send.min_agreement, 0.8);
  EXPECT_EQ(o.contribute.send.min_known, 0.5);
  EXPECT_EQ(o.contribute.send.min_travel, 0.1);
  EXPECT_EQ(o.contribute.send.min_turn_deg, 5.0);
  EXPECT_EQ(o.contribute.max_rejections, 5);
  EXPECT_EQ(o.contribute.pose_offset, Pose2{});
}

TEST(FollowerOptions, ContributionFlagsAreParsed) {
  FollowerOptions o;
  ASSERT_EQ(
      options_error({"--log", "x.clf", "--contribute", "--contribute-min-agreement", "0.9",
                     "--contribute-min-travel", "0.25", "--contribute-min-turn", "10",
                     "--contribute-max-rejections", "3", "--contribute-pose-offset", "0.5,-0.3,4"},
                    &o),
      "");
  EXPECT_TRUE(o.contribute.enabled);
  EXPECT_EQ(o.contribute.send.min_agreement, 0.9);
  EXPECT_EQ(o.contribute.send.min_travel, 0.25);
  EXPECT_EQ(o.contribute.send.min_turn_deg, 10.0);
  EXPECT_EQ(o.contribute.max_rejections, 3);
  EXPECT_DOUBLE_EQ(o.contribute.pose_offset.x, 0.5);
  EXPECT_DOUBLE_EQ(o.contribute.pose_offset.y, -0.3);
  EXPECT_DOUBLE_EQ(o.contribute.pose_offset.theta, 4.0 * std::numbers::pi / 180.0);
}

TEST(FollowerOptions, BadContributionFlagsAreRefusedNamingTheFlag) {
  EXPECT_TRUE(contains(options_error({"--contribute"}), "--contribute sends this robot's scans"));
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      // The rule is core's (ContributorConfig): its fields as contribute.<field>.
      {{"--contribute-min-agreement", "1.5"}, "contribute.min_agreement"},
      {{"--contribute-min-travel", "-1"}, "contribute.min_travel"},
      {{"--contribute-min-turn", "-5"}, "min_turn"},
      {{"--contribute-max-rejections", "0"}, "--contribute-max-rejections"},
      {{"--contribute-pose-offset", "1,2"}, "--contribute-pose-offset '1,2'"},
      {{"--contribute-pose-offset", "1,2,x"}, "--contribute-pose-offset"},
      {{"--contribute-pose-offset", "1,2,3,"}, "--contribute-pose-offset"},
      {{"--contribute-pose-offset", "1,nan,3"}, "--contribute-pose-offset"},
  };
  for (const auto& [flags, expected] : cases) {
    std::vector<std::string> args = {"--log", "x.clf", "--contribute"};
    args.insert(args.end(), flags.begin(), flags.end());
    const std::string error = options_error(args);
    EXPECT_TRUE(contains(error, expected)) << flags.front() << ": " << error;
  }
}

TEST(FollowerOptions, PoseOffsetParsing) {
  const Pose2 p = parse_pose_offset("-1.5,0,90");
  EXPECT_DOUBLE_EQ(p.x, -1.5);
  EXPECT_DOUBLE_EQ(p.y, 0.0);
  EXPECT_DOUBLE_EQ(p.theta, std::numbers::pi / 2);
  EXPECT_THROW(parse_pose_offset(""), std::invalid_argument);
  EXPECT_THROW(parse_pose_offset("1,2,3,4"), std::invalid_argument);
  EXPECT_THROW(parse_pose_offset("1,,3"), std::invalid_argument);
}

TEST(FollowerOptions, TheLeadersMappingParametersAreRefusedAsFlagsAndIgnoredInAConfigFile) {
  // Tracking parameters reach the localiser.
  FollowerOptions o;
  ASSERT_EQ(options_error({"--log", "x.clf", "--prior-sigma-xy", "0.2", "--localise-motion-hold",
                           "0.05", "--seed", "9"},
                          &o),
            "");
  EXPECT_EQ(o.localiser.tracking.prior_sigma_xy, 0.2);
  EXPECT_EQ(o.localiser.seed, 9u);
  // Mapping parameters, and the SLAM's hold (the follower has its own), are not the follower's.
  for (const char* flag : {"--loop-closure", "--free-margin", "--recovery", "--motion-hold"}) {
    const std::string e = options_error({"--log", "x.clf", flag, "0"});
    EXPECT_TRUE(contains(e, std::string(flag) + ": a parameter of the leader's mapping, which "
                                                "esfleet-follower does not use"))
        << e;
  }
  // A config file shared with the leader may hold them.
  const std::filesystem::path yaml = std::filesystem::path(::testing::TempDir()) /
                                     ("follower-shared-" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(yaml) << "loop_closure: off\nprior_sigma_xy: 0.25\n";
  FollowerOptions shared;
  const std::string e = options_error({"--log", "x.clf", "--config", yaml.string()}, &shared);
  std::filesystem::remove(yaml);
  EXPECT_EQ(e, "");
  EXPECT_EQ(shared.localiser.tracking.prior_sigma_xy, 0.25);
  // The log line lists only what changed the follower; the rest as ignored.
  EXPECT_EQ(shared.parameter_changes,
            "1 changed: prior_sigma_xy = 0.25; ignored (not used by this program): "
            "loop_closure = off");
}

}  // namespace
}  // namespace esfleet::follower
