#include "follower_options.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "app/dds_flags.hpp"
#include "app/localise_params.hpp"
#include "app/slam_params.hpp"

namespace esfleet::follower {

void FollowerOptions::validate() const {
  localiser.validate();
  if (!std::isfinite(reader.no_return_range) || !(reader.no_return_range > 0.0f)) {
    throw std::invalid_argument("--no-return-range must be finite and > 0");
  }
  if (timeout < 0.0 || rate < 0.0 || idle_exit < 0.0 || leader_timeout < 0.0) {
    throw std::invalid_argument("--timeout, --rate, --idle-exit and --leader-timeout must be >= 0");
  }
  if (!log.empty() + !scan_robot.empty() + !ros.scan_topic.empty() > 1) {
    throw std::invalid_argument(
        "give at most one of --log FILE, --scan-topic ROBOT_ID and --ros-scan TOPIC");
  }
  if (ros.any() && !secure.empty()) {
    throw std::invalid_argument(
        "--ros and --ros-scan do not work with --secure yet (the ROS topics are not in the "
        "security permissions)");
  }
  if (ros.outputs && !has_scans()) {
    throw std::invalid_argument("--ros publishes this robot's pose: it needs its scans");
  }
  ros.validate(robot_id);
  contribute.validate();
  if (contribute.enabled && !has_scans()) {
    throw std::invalid_argument("--contribute sends this robot's scans: it needs its scans");
  }
}

Pose2 parse_pose_offset(const std::string& text) {
  auto fail = [&] {
    throw std::invalid_argument("--contribute-pose-offset '" + text +
                                "': expected dx,dy,dtheta_deg (metres, metres, degrees)");
  };
  std::vector<double> v;
  std::stringstream in(text);
  std::string part;
  while (std::getline(in, part, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(part, &used));
      if (used != part.size() || !std::isfinite(v.back())) fail();
    } catch (const std::logic_error&) {
      fail();
    }
  }
  if (v.size() != 3 || text.back() == ',') fail();
  return Pose2{v[0], v[1], deg_to_rad(v[2])};
}

void add_follower_flags(CLI::App& cli, FollowerOptions& o, app::ParamTable& params) {
  app::add_dds_flags(cli, o.domain, o.profile, o.secure);
  app::add_ros_flags(cli, o.ros, false);
  cli.add_option("--map-id", o.map_id, "map to follow (default: the first one seen)");
  cli.add_option("--save-map", o.save_dir, "directory to save the map into (at exit, SIGUSR1)");
  cli.add_flag("--exit-when-complete", o.exit_when_complete,
               "without scans: exit (saving) once the leader's map is final and every tile is "
               "here");
  cli.add_option("--timeout", o.timeout, "stop after this many seconds (0 = no limit)")
      ->capture_default_str();
  cli.add_option("--leader-timeout", o.leader_timeout,
                 "report the leader gone when no map summary came for S seconds while it was "
                 "mapping (0 = only when DDS reports its writers gone); the map and tracking "
                 "are kept either way")
      ->capture_default_str();
  auto* log_opt =
      cli.add_option("--log", o.log, "this robot's scans from a CARMEN log (localise in the map)");
  cli.add_option("--scan-topic", o.scan_robot,
                 "this robot's scans from the DDS scan topic, published under this robot id")
      ->excludes(log_opt);
  cli.add_option("--rate", o.rate,
                 "--log: replay speed (1 = recorded speed, 0 = as fast as possible)")
      ->capture_default_str();
  cli.add_option("--max-scans", o.max_scans, "--log: read the first N scans (0 = all)")
      ->capture_default_str();
  cli.add_option("--first-scan", o.first_scan,
                 "--log: start at this scan (skip the ones before; counted from 0)")
      ->capture_default_str();
  cli.add_option("--idle-exit", o.idle_exit,
                 "--scan-topic: end once no scan arrived for this many seconds (0 = never)")
      ->capture_default_str();
  cli.add_option("--latest-only", o.latest_only,
                 "--scan-topic: when scans are waiting, process the newest and skip the older "
                 "ones (real time: no backlog after a global search); false = every scan in order")
      ->capture_default_str();
  cli.add_option("--robot-id", o.robot_id, "this robot's id on the pose topic")
      ->capture_default_str();
  cli.add_option("--hint", o.hint,
                 "start pose guess x,y,theta_deg[,radius_m[,angle_deg]] (default radius 1 m, "
                 "angle 30 deg); without it the search is global");
  cli.add_flag("--wait-complete", o.wait_complete,
               "hold the scans until the leader's map is complete (tests, benchmarks)");
  cli.add_option("--trajectory", o.trajectory_path,
                 "write the tracked poses (stamp x y theta per line) to this file at exit");
  auto* c = cli.add_option_group("Contributed scans",
                                 "Send tracked scans to a leader run with --accept-contributions");
  c->add_flag("--contribute", o.contribute.enabled,
              "while tracking, send scans with strong evidence and the pose to the leader, "
              "which writes the ones it accepts into the shared map; relocalise when it refuses "
              "too many in a row");
  c->add_option("--contribute-min-agreement", o.contribute.send.min_agreement,
                "send only scans whose tracked pose agrees at least this much with the map "
                "(and with at least half the end points on known cells)")
      ->capture_default_str();
  c->add_option("--contribute-min-travel", o.contribute.send.min_travel,
                "send a scan once the robot moved this far (m) since the last one sent ...")
      ->capture_default_str();
  c->add_option("--contribute-min-turn", o.contribute.send.min_turn_deg,
                "... or turned this much (degrees)")
      ->capture_default_str();
  c->add_option("--contribute-max-rejections", o.contribute.max_rejections,
                "relocalise when the leader refused this many scans in a row")
      ->capture_default_str();
  c->add_option("--contribute-pose-offset", o.contribute_pose_offset,
                "test aid: add dx,dy,dtheta_deg to the pose sent with each scan (a robot whose "
                "pose is wrong)");
  app::add_slam_params(params, &o.slam, &o.reader);
  // The map is the leader's: its layout, update, key scans and loop closure are not ours; the
  // hold along the motion is --localise-motion-hold.
  params.not_used(
      [](const std::string& name) {
        return !app::is_tracking_param(name) || name == "motion_hold";
      },
      "a parameter of the leader's mapping, which esfleet-follower does not use (in a --config "
      "file it is accepted and ignored; the follower's hold along the motion is "
      "--localise-motion-hold)");
  app::add_localise_params(params, &o.localiser);
  params.bind(cli, "Tracking and localisation parameters");
}

void finish_follower_options(FollowerOptions& o, app::ParamTable& params) {
  params.apply();
  o.parameter_changes = params.describe_changes();
  if (!o.hint.empty()) o.localiser.hint = app::parse_hint(o.hint);
  o.localiser.tracking = o.slam.tracking;
  o.localiser.seed = o.slam.seed;
  if (!o.contribute_pose_offset.empty()) {
    o.contribute.pose_offset = parse_pose_offset(o.contribute_pose_offset);
  }
  o.validate();
}

}  // namespace esfleet::follower
