#pragma once
// esfleet-follower's options: which map to follow on which DDS domain, where the robot's own
// scans come from (none, a log or its scan topic), what to save, and the localisation
// parameters (tracking uses the SLAM's).

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "app/param_table.hpp"
#include "app/ros_options.hpp"
#include "contributor.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/localiser.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet::follower {

struct FollowerOptions {
  // --- the shared map ---
  int domain = 0;
  std::string profile;              ///< Fast DDS XML profile; empty = Fast DDS defaults
  std::string secure;               ///< DDS Security directory (docs/security.md); empty = off
  std::string map_id;               ///< map to follow; empty = the first one seen
  double leader_timeout = 5.0;      ///< leader gone after this long without a summary while mapping
  bool exit_when_complete = false;  ///< without scans: exit once the leader's map is here whole
  double timeout = 0.0;             ///< stop after this many seconds; 0 = no limit

  // --- outputs ---
  std::string save_dir;         ///< map files and stats.json at exit and on SIGUSR1
  std::string trajectory_path;  ///< the tracked poses at exit

  // --- this robot's scans: none, log, scan_robot or ros.scan_topic ---
  std::string log;
  std::string scan_robot;
  std::string robot_id = "follower";  ///< id on the pose topic
  double rate = 1.0;                  ///< log replay speed; 0 = as fast as possible
  std::size_t max_scans = 0;          ///< log: read the first N scans; 0 = all
  std::size_t first_scan = 0;         ///< log: start at this scan
  double idle_exit = 0.0;             ///< scan topic: end after this many idle seconds
  bool latest_only = true;            ///< scan topic: skip to the newest waiting scan
  bool wait_complete = false;         ///< hold the scans until the leader's map is complete

  // --- contributed scans (contributor.hpp) ---
  ContributorConfig contribute;
  std::string contribute_pose_offset;  ///< tests: "dx,dy,dtheta_deg"; parsed into contribute

  // --- ROS 2 (docs/ros2.md) ---
  app::RosOptions ros;
  // --- localisation ---
  std::string hint;  ///< x,y,theta_deg[,radius_m[,angle_deg]]; empty = global search
  /// The tracking parameters come from a whole SLAM configuration (same flags as the leader);
  /// finish_follower_options copies its tracking part and seed into `localiser`.
  SlamConfig slam;
  LocaliserConfig localiser;
  CarmenReaderOptions reader;
  std::string parameter_changes;  ///< for the log: "all defaults" or "N changed: ..."

  /// Throws std::invalid_argument naming the flag.
  void validate() const;
  bool has_scans() const { return !log.empty() || !scan_robot.empty() || !ros.scan_topic.empty(); }
};

/// Registers every flag on `cli`, bound to `o` and (the parameters) `params`.
void add_follower_flags(CLI::App& cli, FollowerOptions& o, app::ParamTable& params);

/// After parsing: applies the parameter file and flags, the hint and the seed, and validates.
/// Throws std::invalid_argument or app::UsageError naming the flag, file or line.
void finish_follower_options(FollowerOptions& o, app::ParamTable& params);

/// "dx,dy,dtheta_deg" as a pose offset (theta in radians). Throws std::invalid_argument naming
/// --contribute-pose-offset for anything else.
Pose2 parse_pose_offset(const std::string& text);

}  // namespace esfleet::follower
