// The ROS 2 flags (app/ros_options.hpp): parsing, checks that name the flag, resolved names.

#include "app/ros_options.hpp"

#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace esfleet::app {
namespace {

RosOptions parse(std::vector<std::string> args, bool leader = true) {
  RosOptions o;
  CLI::App cli;
  add_ros_flags(cli, o, leader);
  args.insert(args.begin(), "prog");
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  cli.parse(static_cast<int>(argv.size()), argv.data());
  return o;
}

/// The message of the std::invalid_argument that validate() throws, "" if none.
std::string validation_error(const RosOptions& o, const std::string& robot_id) {
  try {
    o.validate(robot_id);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(RosOptions, OffByDefaultAndAnyRobotIdIsFineWithoutRos) {
  const RosOptions o = parse({});
  EXPECT_FALSE(o.any());
  EXPECT_EQ(validation_error(o, "robot-1"), "");  // not a ROS name, but the ROS side is off
  EXPECT_DOUBLE_EQ(o.map_period, 30.0);
}

TEST(RosOptions, ABadDefaultNamespaceNamesTheFlag) {
  const RosOptions o = parse({"--ros"});
  const std::string e = validation_error(o, "robot-1");
  EXPECT_NE(e.find("--ros-namespace (default /ROBOT_ID)"), std::string::npos) << e;
  EXPECT_NE(e.find("robot-1"), std::string::npos) << e;
  EXPECT_EQ(validation_error(parse({"--ros", "--ros-namespace", "/robot_1"}), "robot-1"), "");
}

TEST(RosOptions, ChecksNameTheFlag) {
  EXPECT_NE(validation_error(parse({"--ros-scan", "a//b"}), "r1").find("--ros-scan"),
            std::string::npos);
  EXPECT_NE(validation_error(parse({"--ros-odom", "odom"}), "r1").find("needs --ros-scan"),
            std::string::npos);
  EXPECT_NE(validation_error(parse({"--ros", "--odom-frame", "od-om"}), "r1").find("--odom-frame"),
            std::string::npos);
  EXPECT_NE(validation_error(parse({"--ros-map-period", "0"}), "r1").find("--ros-map-period"),
            std::string::npos);
  EXPECT_THROW(parse({"--laser-pose", "1,2"}), CLI::ValidationError);
  EXPECT_THROW(parse({"--laser-pose", "1,2,nan"}), CLI::ValidationError);
  EXPECT_THROW(parse({"--ros-map-period", "5"}, /*leader=*/false), CLI::ExtrasError);
}

TEST(RosOptions, ResolvedNamesFollowTheNamespace) {
  const RosOptions o =
      parse({"--ros", "--ros-scan", "scan", "--ros-odom", "odom", "--laser-pose", "0.1,-0.2,90"});
  ASSERT_EQ(validation_error(o, "robot1"), "");
  const RosNames n = resolve_ros_names(o, "robot1");
  EXPECT_EQ(n.ns, "/robot1");
  EXPECT_EQ(n.scan_topic, "/robot1/scan");
  EXPECT_EQ(n.odom_topic, "/robot1/odom");
  EXPECT_FALSE(n.odom_from_tf);
  EXPECT_EQ(n.pose_topic, "/robot1/pose");
  EXPECT_EQ(n.initialpose_topic, "/robot1/initialpose");
  EXPECT_EQ(n.map_frame, "map");
  EXPECT_EQ(n.odom_frame, "robot1/odom");
  EXPECT_EQ(n.base_frame, "robot1/base_link");
  ASSERT_TRUE(o.laser_pose.has_value());
  EXPECT_DOUBLE_EQ(o.laser_pose->x, 0.1);
  EXPECT_NEAR(o.laser_pose->theta, std::numbers::pi / 2, 1e-12);

  const RosNames root = resolve_ros_names(
      parse({"--ros-scan", "/front/scan", "--ros-odom", "tf", "--ros-namespace", "/"}), "robot1");
  EXPECT_EQ(root.scan_topic, "/front/scan");  // absolute: not under the namespace
  EXPECT_TRUE(root.odom_from_tf);
  EXPECT_EQ(root.odom_topic, "");
  EXPECT_EQ(root.pose_topic, "/pose");
  EXPECT_EQ(root.odom_frame, "odom");
}

}  // namespace
}  // namespace esfleet::app
