// esfleet-replay's command line: flags parsed from an argv into ReplayOptions (--odometry on|off
// into a bool, the --ros flags), and validate() naming the flag whose value is wrong.
#include "replay_options.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
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

TEST(ReplayFlags, RosModeDefaults) {
  ReplayOptions o;
  ASSERT_EQ(parse(o, {"--log", "a", "--robot-id", "robot1", "--ros"}), std::nullopt);
  EXPECT_TRUE(o.ros);
  EXPECT_EQ(o.ros_namespace, "");
  EXPECT_EQ(o.ros_ns(), "/robot1");
  EXPECT_EQ(o.odom_frame, "odom");
  EXPECT_EQ(o.base_frame, "base_link");
  EXPECT_EQ(o.laser_frame, "laser");
  EXPECT_EQ(o.laser_pose, Pose2{});
  EXPECT_EQ(usage_error(o), "");
  ReplayOptions plain;
  ASSERT_EQ(parse(plain, {"--log", "a", "--robot-id", "robot1"}), std::nullopt);
  EXPECT_FALSE(plain.ros);
}

TEST(ReplayFlags, RosFlagsParse) {
  ReplayOptions o;
  ASSERT_EQ(parse(o, {"--log", "a", "--robot-id", "r-1", "--ros", "--ros-namespace", "/",
                      "--odom-frame", "odom_combined", "--base-frame", "base_footprint",
                      "--laser-frame", "base_scan", "--laser-pose", "0.12,-0.05,180"}),
            std::nullopt);
  EXPECT_EQ(o.ros_ns(), "/");
  EXPECT_EQ(o.odom_frame, "odom_combined");
  EXPECT_EQ(o.base_frame, "base_footprint");
  EXPECT_EQ(o.laser_frame, "base_scan");
  EXPECT_EQ(o.laser_pose.x, 0.12);
  EXPECT_EQ(o.laser_pose.y, -0.05);
  EXPECT_NEAR(std::abs(o.laser_pose.theta), std::numbers::pi, 1e-12);
  EXPECT_EQ(usage_error(o), "");  // "r-1" is no ROS name, but the namespace is given
  ReplayOptions eq;
  ASSERT_EQ(parse(eq, {"--log", "a", "--robot-id", "r", "--ros", "--laser-pose=-0.2,0.1,-90"}),
            std::nullopt);
  EXPECT_EQ(eq.laser_pose.x, -0.2);
  EXPECT_NEAR(eq.laser_pose.theta, -std::numbers::pi / 2, 1e-15);
}

TEST(ReplayFlags, RosFlagsNeedRosAndLaserPoseNeedsThreeNumbers) {
  for (const char* flag : {"--ros-namespace", "--odom-frame", "--base-frame", "--laser-frame"}) {
    ReplayOptions o;
    EXPECT_EQ(parse(o, {"--log", "a", "--robot-id", "r", flag, "x"}),
              std::optional<int>(app::kExitUsage))
        << flag;
  }
  ReplayOptions lp;
  EXPECT_EQ(parse(lp, {"--log", "a", "--robot-id", "r", "--laser-pose", "0,0,0"}),
            std::optional<int>(app::kExitUsage));
  for (const char* bad :
       {"1,2", "1,2,3,4", "a,0,0", "0,0,nan", "0,0,inf", "0;0;0", "", "1,,2", "1,2,3x"}) {
    ReplayOptions o;
    EXPECT_EQ(parse(o, {"--log", "a", "--robot-id", "r", "--ros", "--laser-pose", bad}),
              std::optional<int>(app::kExitUsage))
        << bad;
  }
  EXPECT_THROW(parse_laser_pose("1,2"), std::invalid_argument);
  EXPECT_EQ(parse_laser_pose(" 1.5,2,0").x, 1.5);
  EXPECT_NEAR(parse_laser_pose("0,0,540").theta, std::numbers::pi, 1e-12);
}

TEST(ReplayOptionsValidate, RosNamesTheFlag) {
  ReplayOptions o;
  o.log = "a.clf";
  o.robot_id = "robot1";
  o.ros = true;
  EXPECT_EQ(usage_error(o), "");
  o.secure = "/etc/esfleet/security";
  EXPECT_EQ(usage_error(o).rfind("--ros cannot be used with --secure", 0), 0u) << usage_error(o);
  o.secure.clear();

  o.robot_id = "robot-1";  // the default namespace /robot-1 is no ROS name
  std::string e = usage_error(o);
  EXPECT_EQ(e.rfind("--ros-namespace: the default /robot-1 (from --robot-id)", 0), 0u) << e;
  EXPECT_NE(e.find("give --ros-namespace"), std::string::npos) << e;
  o.ros_namespace = "/fleet/robot_1";
  EXPECT_EQ(usage_error(o), "");
  EXPECT_EQ(o.ros_ns(), "/fleet/robot_1");
  for (const char* bad : {"/robot1/", "/1robot", "/a//b", "robot 1"}) {
    o.ros_namespace = bad;
    e = usage_error(o);
    EXPECT_EQ(e.rfind("--ros-namespace: ", 0), 0u) << bad << ": " << e;
    EXPECT_NE(e.find(std::string("'") + bad + "'"), std::string::npos) << e;
  }
  o.ros_namespace = "/";
  EXPECT_EQ(usage_error(o), "");

  o.odom_frame = "/odom";
  EXPECT_EQ(usage_error(o).rfind("--odom-frame '/odom': a frame id has no leading '/'", 0), 0u)
      << usage_error(o);
  o.odom_frame = "odom";
  o.base_frame = "base-link";
  EXPECT_EQ(usage_error(o).rfind("--base-frame: ROS name 'base-link'", 0), 0u) << usage_error(o);
  o.base_frame = "base_link";
  o.laser_frame = "";
  EXPECT_EQ(usage_error(o).rfind("--laser-frame: ", 0), 0u) << usage_error(o);
  o.laser_frame = "base_link";
  EXPECT_EQ(usage_error(o).rfind("--odom-frame, --base-frame and --laser-frame must differ", 0), 0u)
      << usage_error(o);
  o.laser_frame = "laser";
  o.laser_pose.theta = std::nan("");
  EXPECT_EQ(usage_error(o), "--laser-pose must be finite");
  o.laser_pose.theta = 0.0;

  // Without --ros the ROS fields are not looked at.
  o.ros = false;
  o.ros_namespace = "/bad-ns";
  o.secure = "/etc/esfleet/security";
  EXPECT_EQ(usage_error(o), "");
}

}  // namespace
}  // namespace esfleet::sim
