// The command lines esfleet-fleet gives the leader, the followers and the simulator.
#include "child_args.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

namespace esfleet::fleet {
namespace {

using Args = std::vector<std::string>;

FleetOptions options() {
  FleetOptions o;
  o.out = "OUT";
  o.domain = 9;
  o.profile = "p.xml";
  o.log = "a.clf";
  o.world = "w.yaml";
  o.robots = 3;
  o.seed = 7;
  return o;
}

TEST(ChildArgs, SplitArgsAtAnyWhiteSpace) {
  EXPECT_EQ(split_args("  --odometry on\t--mu  50 "), (Args{"--odometry", "on", "--mu", "50"}));
  EXPECT_EQ(split_args(""), Args{});
}

TEST(ChildArgs, LeaderMapsTheLogAndLingers) {
  const FleetOptions o = options();
  EXPECT_EQ(leader_argv(o, "BIN"), (Args{"BIN/esfleet-leader",
                                         "--log",
                                         "a.clf",
                                         "--rate",
                                         "0.000000",
                                         "--linger",
                                         "-1",
                                         "--out",
                                         "OUT/leader",
                                         "--domain",
                                         "9",
                                         "--profile",
                                         "p.xml",
                                         "--odometry",
                                         "on",
                                         "--loop-final",
                                         "off",
                                         "--loop-window-max-xy",
                                         "0",
                                         "--free-margin",
                                         "0",
                                         "--search-point-spacing",
                                         "0"}));
}

TEST(ChildArgs, ARestartedLeaderResumesItsCheckpoint) {
  const Args a = leader_argv(options(), "BIN", /*resume=*/true);
  const auto it = std::find(a.begin(), a.end(), "--resume");
  ASSERT_NE(it, a.end());
  EXPECT_EQ(*(it + 1), "OUT/leader");
  // The same log: the leader skips what its checkpoint holds.
  EXPECT_EQ(a[1], "--log");
  EXPECT_EQ(a[2], "a.clf");
}

TEST(ChildArgs, ContributeMakesTheLeaderAcceptAndEveryFollowerContribute) {
  FleetOptions o = options();
  o.contribute = true;
  o.leader_scans = 994;
  const Args l = leader_argv(o, "BIN");
  const auto it = std::find(l.begin(), l.end(), "--max-scans");
  ASSERT_NE(it, l.end());
  EXPECT_EQ(*(it + 1), "994");
  EXPECT_NE(std::find(l.begin(), l.end(), "--accept-contributions"), l.end());
  for (int k = 1; k <= 3; ++k) {
    const Args f = follower_argv(o, "BIN", k);
    EXPECT_NE(std::find(f.begin(), f.end(), "--contribute"), f.end()) << k;
  }
  // Without it: neither, and the leader maps the whole log.
  const Args plain = leader_argv(options(), "BIN");
  EXPECT_EQ(std::find(plain.begin(), plain.end(), "--accept-contributions"), plain.end());
  EXPECT_EQ(std::find(plain.begin(), plain.end(), "--max-scans"), plain.end());
  const Args f = follower_argv(options(), "BIN", 1);
  EXPECT_EQ(std::find(f.begin(), f.end(), "--contribute"), f.end());
}

TEST(ChildArgs, NetnsRunsEachProgramOnItsTestbedHost) {
  FleetOptions o = options();
  const Args f = follower_argv(o, "BIN", 2);
  EXPECT_EQ(on_host(o, follower_host(2), f), f);  // --netns off: unchanged
  o.netns = "t1";
  const Args wrapped = on_host(o, follower_host(2), f);
  ASSERT_EQ(wrapped.size(), f.size() + 4);
  EXPECT_EQ(wrapped[0].substr(wrapped[0].size() - 3), "/ip");
  EXPECT_EQ((Args{wrapped[1], wrapped[2], wrapped[3]}), (Args{"netns", "exec", "esf-t1-4"}));
  EXPECT_EQ(Args(wrapped.begin() + 4, wrapped.end()), f);
  EXPECT_EQ(on_host(o, kLeaderHost, {"x"}).at(3), "esf-t1-1");
  EXPECT_EQ(on_host(o, kSimHost, {"x"}).at(3), "esf-t1-2");
}

TEST(ChildArgs, FollowerKListensToRobotKWithSeedPlusK) {
  FleetOptions o = options();
  o.follower_args = "--latest-only false";
  EXPECT_EQ(
      follower_argv(o, "BIN", 2),
      (Args{"BIN/esfleet-follower", "--scan-topic", "robot-2", "--robot-id", "robot-2", "--seed",
            "9", "--save-map", "OUT/robot-2", "--trajectory", "OUT/robot-2/trajectory.txt",
            "--domain", "9", "--profile", "p.xml", "--latest-only", "false"}));
}

TEST(ChildArgs, SimulatorDrivesEveryRobot) {
  FleetOptions o = options();
  o.rate = 2.5;
  o.sim_args = "--speed 0.3";
  EXPECT_EQ(sim_argv(o, "BIN"),
            (Args{"BIN/esfleet-sim", "--world", "w.yaml", "--robots", "3", "--rate", "2.500000",
                  "--seed", "7", "--domain", "9", "--profile", "p.xml", "--speed", "0.3"}));
}

TEST(ChildArgs, ViewServesOnItsPortWithItsOwnIdentity) {
  FleetOptions o = options();
  o.view_port = 8080;
  o.view_args = "--bind 127.0.0.1";
  EXPECT_EQ(view_argv(o, "BIN"), (Args{"BIN/esfleet-view", "--port", "8080", "--domain", "9",
                                       "--profile", "p.xml", "--bind", "127.0.0.1"}));
  o.secure = "certs";
  const Args v = view_argv(o, "BIN");
  const auto it = std::find(v.begin(), v.end(), "--secure");
  ASSERT_NE(it, v.end());
  EXPECT_EQ(*(it + 1), "certs/view");
}

TEST(ChildArgs, SecureGivesEachProgramItsOwnIdentity) {
  FleetOptions o = options();
  EXPECT_EQ(dds_args(o, "leader"), (Args{"--domain", "9", "--profile", "p.xml"}));
  o.secure = "certs";
  EXPECT_EQ(dds_args(o, "sim"),
            (Args{"--domain", "9", "--profile", "p.xml", "--secure", "certs/sim"}));
  const Args f = follower_argv(o, "BIN", 3);
  const auto it = std::find(f.begin(), f.end(), "--secure");
  ASSERT_NE(it, f.end());
  EXPECT_EQ(*(it + 1), "certs/robot-3");
}

}  // namespace
}  // namespace esfleet::fleet
