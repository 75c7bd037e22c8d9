#include "app/ros_options.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "esfleet/dds/ros.hpp"

namespace esfleet::app {
namespace {

/// Parses "x,y,yaw_deg" (--laser-pose).
Pose2 parse_pose(const std::string& text) {
  Pose2 p;
  char extra = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &p.x, &p.y, &p.theta, &extra) != 3 ||
      !std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.theta)) {
    throw CLI::ValidationError("--laser-pose",
                               "'" + text + "' is not X,Y,YAW_DEG (metres, metres, degrees)");
  }
  p.theta = normalize_angle(deg_to_rad(p.theta));
  return p;
}

}  // namespace

std::string RosOptions::resolved_ns(const std::string& robot_id) const {
  return ns ? *ns : "/" + robot_id;
}

void RosOptions::validate(const std::string& robot_id) const {
  if (!(map_period > 0.0)) throw std::invalid_argument("--ros-map-period must be > 0");
  if (!odom.empty() && scan_topic.empty()) {
    throw std::invalid_argument("--ros-odom needs --ros-scan (odometry goes with ROS scans)");
  }
  if (!any()) return;  // the names matter only when the ROS side is on
  auto check = [](const char* flag, auto&& body) {
    try {
      body();
    } catch (const dds::RosNameError& e) {
      throw std::invalid_argument(std::string(flag) + ": " + e.what());
    }
  };
  check(ns ? "--ros-namespace" : "--ros-namespace (default /ROBOT_ID)",
        [&] { (void)dds::ros_name(resolved_ns(robot_id), "pose"); });
  if (!scan_topic.empty()) check("--ros-scan", [&] { (void)dds::ros_name("/", scan_topic); });
  if (!odom.empty() && odom != "tf") check("--ros-odom", [&] { (void)dds::ros_name("/", odom); });
  for (const auto& [flag, frame] :
       {std::pair{"--map-frame", &map_frame}, std::pair{"--odom-frame", &odom_frame},
        std::pair{"--base-frame", &base_frame}}) {
    check(flag, [&] { (void)dds::ros_name("/", *frame); });
  }
}

RosNames resolve_ros_names(const RosOptions& o, const std::string& robot_id) {
  RosNames n;
  n.ns = o.resolved_ns(robot_id);
  if (!o.scan_topic.empty()) n.scan_topic = dds::ros_name(n.ns, o.scan_topic);
  n.odom_from_tf = o.odom == "tf";
  if (!o.odom.empty() && !n.odom_from_tf) n.odom_topic = dds::ros_name(n.ns, o.odom);
  n.pose_topic = dds::ros_name(n.ns, "pose");
  n.initialpose_topic = dds::ros_name(n.ns, "initialpose");
  n.map_frame = o.map_frame;
  n.odom_frame = dds::ros_frame(n.ns, o.odom_frame);
  n.base_frame = dds::ros_frame(n.ns, o.base_frame);
  return n;
}

void add_ros_flags(CLI::App& cli, RosOptions& o, bool leader) {
  auto* g = cli.add_option_group(
      "ROS 2", "ROS 2 topics on the same DDS domain (no ROS installation needed; docs/ros2.md)");
  g->add_flag("--ros", o.outputs,
              leader ? "publish /map, /map_updates, <ns>/pose and TF map -> <ns>/odom"
                     : "publish <ns>/pose and TF map -> <ns>/odom, take <ns>/initialpose");
  g->add_option("--ros-scan", o.scan_topic,
                "read sensor_msgs/LaserScan from this ROS topic (relative names go under the "
                "namespace, e.g. scan -> /robot1/scan) instead of a log")
      ->type_name("TOPIC");
  g->add_option("--ros-odom", o.odom,
                "with --ros-scan: odometry from this nav_msgs/Odometry topic (e.g. odom), or "
                "'tf' for the odom -> base transform on /tf; default: laser only")
      ->type_name("TOPIC|tf");
  g->add_option("--ros-namespace", o.ns,
                "the robot's ROS namespace (default: /ROBOT_ID; '/' = none)")
      ->type_name("NS");
  g->add_option("--map-frame", o.map_frame, "the map's TF frame")
      ->type_name("FRAME")
      ->capture_default_str();
  g->add_option("--odom-frame", o.odom_frame, "odometry frame, under the namespace")
      ->type_name("FRAME")
      ->capture_default_str();
  g->add_option("--base-frame", o.base_frame, "robot base frame, under the namespace")
      ->type_name("FRAME")
      ->capture_default_str();
  g->add_option("--laser-frame", o.laser_frame,
                "the laser's frame id; scans of other frames are dropped (default: the first "
                "scan's)")
      ->type_name("FRAME");
  g->add_option_function<std::string>(
       "--laser-pose", [&o](const std::string& v) { o.laser_pose = parse_pose(v); },
       "the laser's pose on the base as X,Y,YAW_DEG (default: from /tf_static with odometry, "
       "else 0,0,0)")
      ->type_name("X,Y,YAW_DEG");
  if (leader) {
    g->add_option("--ros-map-period", o.map_period,
                  "seconds of scan time between whole /map messages; changed tiles go on "
                  "/map_updates at every publish, and a whole /map also goes when the map grew "
                  "or a new /map reader joined")
        ->capture_default_str();
  }
}

}  // namespace esfleet::app
