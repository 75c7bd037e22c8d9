#include "replay_options.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>

#include "app/dds_flags.hpp"
#include "app/program.hpp"
#include "esfleet/dds/ros.hpp"
#include "esfleet/dds/topics.hpp"

namespace esfleet::sim {

using app::UsageError;

namespace {

/// A frame id flag: a relative ROS name (it goes under the namespace).
void check_frame(const std::string& flag, const std::string& frame) {
  if (!frame.empty() && frame.front() == '/') {
    throw UsageError(flag + " '" + frame + "': a frame id has no leading '/' (the namespace " +
                     "goes in front of it)");
  }
  try {
    dds::ros_name("/", frame);
  } catch (const dds::RosNameError& e) {
    throw UsageError(flag + ": " + e.what());
  }
}

}  // namespace

Pose2 parse_laser_pose(const std::string& text) {
  double v[3] = {0.0, 0.0, 0.0};
  const char* p = text.c_str();
  for (int i = 0; i < 3; ++i) {
    char* end = nullptr;
    v[i] = std::strtod(p, &end);
    if (end == p || !std::isfinite(v[i]) || (i < 2 ? *end != ',' : *end != '\0')) {
      throw std::invalid_argument("'" + text + "' is not X,Y,YAW_DEG (three finite numbers)");
    }
    p = end + 1;
  }
  return Pose2{v[0], v[1], normalize_angle(deg_to_rad(v[2]))};
}

std::string ReplayOptions::ros_ns() const {
  return ros_namespace.empty() ? "/" + robot_id : ros_namespace;
}

void ReplayOptions::validate() const {
  if (robot_id.empty()) throw UsageError("--robot-id must not be empty");
  if (robot_id.size() > 64) throw UsageError("--robot-id: at most 64 characters");
  if (!(rate >= 0.0) || rate > 1e6) throw UsageError("--rate must be in [0, 1e6]");
  if (domain < 0 || domain > dds::kMaxDomain) throw UsageError("--domain must be in [0, 232]");
  if (wait_subscribers < 0) throw UsageError("--wait-subscribers must be >= 0");
  if (!(wait_timeout >= 0.0)) throw UsageError("--wait-timeout must be >= 0");
  if (!ros) return;
  if (!secure.empty()) {
    throw UsageError(
        "--ros cannot be used with --secure: the ROS 2 topics are not in the DDS Security "
        "permissions (docs/security.md)");
  }
  try {
    dds::ros_name(ros_ns(), "scan");
  } catch (const dds::RosNameError& e) {
    if (!ros_namespace.empty()) throw UsageError(std::string("--ros-namespace: ") + e.what());
    throw UsageError("--ros-namespace: the default " + ros_ns() +
                     " (from --robot-id) is not a ROS namespace (" + e.what() +
                     "); give --ros-namespace");
  }
  check_frame("--odom-frame", odom_frame);
  check_frame("--base-frame", base_frame);
  check_frame("--laser-frame", laser_frame);
  if (odom_frame == base_frame || base_frame == laser_frame || odom_frame == laser_frame) {
    throw UsageError("--odom-frame, --base-frame and --laser-frame must differ (" + odom_frame +
                     ", " + base_frame + ", " + laser_frame + ")");
  }
  if (!std::isfinite(laser_pose.x) || !std::isfinite(laser_pose.y) ||
      !std::isfinite(laser_pose.theta)) {
    throw UsageError("--laser-pose must be finite");
  }
}

void add_replay_flags(CLI::App& cli, ReplayOptions& o) {
  cli.add_option("--log", o.log, "CARMEN log to publish")->required();
  cli.add_option("--robot-id", o.robot_id, "robot id the scans are published under")->required();
  cli.add_option("--rate", o.rate,
                 "speed: 1 = as recorded, 2 = twice as fast, 0 = as fast as the readers "
                 "acknowledge (--ros: 500 scans/s, its readers are best-effort)")
      ->capture_default_str();
  app::add_dds_flags(cli, o.domain, o.profile, o.secure);
  cli.add_option("--first-scan", o.first_scan,
                 "start at this scan of the log (counted from 0, before --max-scans applies)")
      ->capture_default_str();
  cli.add_option("--max-scans", o.max_scans, "publish only the first N scans (0 = all)")
      ->capture_default_str();
  cli.add_option("--wait-subscribers", o.wait_subscribers,
                 "before the first scan, wait until N scan readers are matched (with --ros: of "
                 "<ns>/scan; 0 = start at once)")
      ->capture_default_str();
  cli.add_option("--wait-timeout", o.wait_timeout,
                 "wait at most S seconds for them, then start anyway")
      ->capture_default_str();
  // on|off on the command line, a bool in the options.
  cli.add_option_function<std::string>(
         "--odometry", [&o](const std::string& v) { o.odometry = v == "on"; },
         "send the log's odometry with each scan")
      ->check(CLI::IsMember({"on", "off"}))
      ->default_str(o.odometry ? "on" : "off");

  CLI::Option* ros = cli.add_flag(
      "--ros", o.ros,
      "publish what a ROS 2 robot would instead of esfleet's scan topic: per scan the odometry "
      "on <ns>/odom and the odom -> base transform on /tf (with --odometry on), then the "
      "sensor_msgs/LaserScan on <ns>/scan, stamped with the log's times; once at the start the "
      "base -> laser transform on /tf_static. Not with --secure");
  cli.add_option("--ros-namespace", o.ros_namespace,
                 "ROS namespace of the topics and frames (\"/\" = none)")
      ->default_str("/<robot-id>")
      ->needs(ros);
  cli.add_option("--odom-frame", o.odom_frame, "odometry frame id (under the namespace)")
      ->capture_default_str()
      ->needs(ros);
  cli.add_option("--base-frame", o.base_frame, "robot base frame id (under the namespace)")
      ->capture_default_str()
      ->needs(ros);
  cli.add_option("--laser-frame", o.laser_frame,
                 "laser frame id (under the namespace), the scans' frame")
      ->capture_default_str()
      ->needs(ros);
  cli.add_option_function<std::string>(
         "--laser-pose",
         [&o](const std::string& v) {
           try {
             o.laser_pose = parse_laser_pose(v);
           } catch (const std::invalid_argument& e) {
             throw CLI::ValidationError("--laser-pose", e.what());
           }
         },
         "the laser's mount on the base, X,Y in metres and YAW in degrees "
         "(/tf_static base -> laser)")
      ->type_name("X,Y,YAW_DEG")
      ->default_str("0,0,0")
      ->needs(ros);
}

}  // namespace esfleet::sim
