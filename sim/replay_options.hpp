#pragma once
// esfleet-replay's command line: what to publish and how fast (ReplayOptions), its checks
// (validate) and the flags that set it (add_replay_flags), apart from main() so that a test can
// parse an argv into it.

#include <CLI/CLI.hpp>
#include <cstddef>
#include <string>

#include "esfleet/core/geometry.hpp"

namespace esfleet::sim {

struct ReplayOptions {
  std::string log;             ///< CARMEN log to publish (required)
  std::string robot_id;        ///< key of the scans on the topic (required), at most 64 chars
  double rate = 1.0;           ///< 1 = recorded speed, 2 = twice as fast, 0 = as fast as possible
  int domain = 0;              ///< DDS domain id
  std::string profile;         ///< Fast DDS XML profile; empty = Fast DDS defaults
  std::string secure;          ///< DDS Security directory (docs/security.md); empty = off
  std::size_t max_scans = 0;   ///< publish only the first N scans; 0 = all
  std::size_t first_scan = 0;  ///< skip the scans before this one
  int wait_subscribers = 1;    ///< before the first scan, wait for this many scan readers
  double wait_timeout = 30.0;  ///< ... at most this many seconds (then start anyway)
  bool odometry = true;        ///< send the log's odometry with each scan (--odometry on|off)

  // --ros: publish what a ROS 2 robot would (sim/ros_replay_writer.hpp) instead of esfleet's
  // scan topic.
  bool ros = false;
  std::string ros_namespace;        ///< "" = "/<robot-id>"; "/" = no namespace
  std::string odom_frame = "odom";  ///< frame ids, put under the namespace (ros_frame)
  std::string base_frame = "base_link";
  std::string laser_frame = "laser";
  Pose2 laser_pose;  ///< the laser in the base frame (--laser-pose X,Y,YAW_DEG)

  /// The ROS namespace in use: --ros-namespace, else "/<robot-id>".
  std::string ros_ns() const;

  /// Throws app::UsageError naming the flag. (Whether --first-scan lies inside the log is
  /// known only once it is read: ReplayApp checks that.)
  void validate() const;
};

/// "X,Y,YAW_DEG" (metres, metres, degrees) as a pose (yaw in radians); throws
/// std::invalid_argument saying what is wrong.
Pose2 parse_laser_pose(const std::string& text);

/// Registers esfleet-replay's flags on `cli`, bound to `o` (its values are the defaults shown).
void add_replay_flags(CLI::App& cli, ReplayOptions& o);

}  // namespace esfleet::sim
