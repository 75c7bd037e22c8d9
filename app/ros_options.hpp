#pragma once
// The ROS 2 side of a robot program (leader and follower): where its scans and odometry come
// from on ROS topics, which outputs it writes, its namespace and TF frame names (REP 105:
// map -> <robot>/odom -> <robot>/base_link -> laser). docs/ros2.md has the topic table.

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "esfleet/core/geometry.hpp"

namespace esfleet::app {

struct RosOptions {
  bool outputs = false;           ///< --ros: write the ROS outputs (pose, TF; leader: /map too)
  std::string scan_topic;         ///< --ros-scan: read sensor_msgs/LaserScan here; "" = not
  std::string odom;               ///< --ros-odom TOPIC | tf; "" = laser only (the default)
  std::optional<std::string> ns;  ///< --ros-namespace; default "/<robot id>"
  std::string map_frame = "map";
  std::string odom_frame = "odom";       ///< under the namespace
  std::string base_frame = "base_link";  ///< under the namespace
  /// The laser's frame id (as the driver stamps it, not put under the namespace); scans of any
  /// other frame are dropped. "" = the frame of the first valid scan.
  std::string laser_frame;
  /// --laser-pose: the laser's pose on the base (base -> laser); unset = from /tf_static when
  /// odometry is used, else identity.
  std::optional<Pose2> laser_pose;
  double map_period = 30.0;  ///< leader: seconds of scan time between whole /map messages

  /// The namespace: --ros-namespace, or "/<robot_id>".
  std::string resolved_ns(const std::string& robot_id) const;
  /// The ROS side is used at all (an input or the outputs).
  bool any() const { return outputs || !scan_topic.empty(); }
  /// Throws std::invalid_argument naming the flag: bad ROS names or frames, --ros-odom without
  /// --ros-scan, a non-positive --ros-map-period.
  void validate(const std::string& robot_id) const;
};

/// The resolved names one robot uses (fully qualified topics, frames under its namespace).
struct RosNames {
  std::string ns;
  std::string scan_topic;  ///< "" when scans do not come from ROS
  std::string odom_topic;  ///< "" unless odometry comes from a topic
  bool odom_from_tf = false;
  std::string pose_topic;         ///< <ns>/pose
  std::string initialpose_topic;  ///< <ns>/initialpose
  std::string map_frame;
  std::string odom_frame;  ///< e.g. robot1/odom
  std::string base_frame;  ///< e.g. robot1/base_link
};
/// Throws dds::RosNameError naming a bad name.
RosNames resolve_ros_names(const RosOptions& o, const std::string& robot_id);

/// Registers the ROS flags on `cli` in a "ROS 2" group; `leader` adds --ros-map-period.
void add_ros_flags(CLI::App& cli, RosOptions& o, bool leader);

}  // namespace esfleet::app
