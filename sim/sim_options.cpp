#include "sim_options.hpp"

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "app/dds_flags.hpp"
#include "app/program.hpp"
#include "esfleet/dds/topics.hpp"

namespace esfleet::sim {

using app::UsageError;

FleetConfig SimOptions::fleet_config() const {
  FleetConfig f = fleet;
  f.start_stamp = start_stamp ? *start_stamp
                              : std::floor(std::chrono::duration<double>(
                                               std::chrono::system_clock::now().time_since_epoch())
                                               .count());
  return f;
}

void SimOptions::validate() const {
  if (start_stamp && !(*start_stamp >= 0.0)) throw UsageError("--start-stamp must be >= 0");
  try {
    fleet_config().validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());  // names the flag already
  }
  if (!(duration >= 0.0 && duration <= 1e7)) throw UsageError("--duration must be in [0, 1e7]");
  if (domain < 0 || domain > dds::kMaxDomain) throw UsageError("--domain must be in [0, 232]");
  if (offline && out_log.empty()) throw UsageError("--offline needs --out-log DIR");
  if (offline && duration <= 0.0) throw UsageError("--offline needs --duration > 0");
  if (wait_subscribers < 0) throw UsageError("--wait-subscribers must be >= 0");
  if (!(wait_timeout >= 0.0)) throw UsageError("--wait-timeout must be >= 0");
}

void add_sim_flags(CLI::App& cli, SimOptions& o) {
  auto& f = o.fleet;
  cli.add_option("--world", o.world, "world map: ROS map_server YAML (PGM or PNG image)")
      ->required();
  cli.add_option("--robots", f.robots, "number of robots")->capture_default_str();
  cli.add_option("--id-prefix", f.id_prefix, "robot k (1..N) is <prefix><k>")
      ->capture_default_str();
  cli.add_option("--seed", f.seed, "seed of everything random (starts, goals, noise)")
      ->capture_default_str();
  cli.add_option("--speed", f.motion.speed, "maximum forward speed, m/s")->capture_default_str();
  cli.add_option("--turn-rate", f.motion.turn_rate_deg, "maximum turn rate, deg/s")
      ->capture_default_str();
  cli.add_option("--clearance", f.motion.clearance,
                 "least distance (m) of a robot's centre to occupied or unknown space")
      ->capture_default_str();
  cli.add_option("--plan-cell", f.motion.plan_cell, "A* grid cell, m (whole world cells)")
      ->capture_default_str();
  cli.add_option("--rate", f.rate, "scans per second per robot (Hz)")->capture_default_str();
  cli.add_option("--beams", f.laser.beams, "beams per scan")->capture_default_str();
  cli.add_option("--fov", f.laser.fov_deg, "field of view, deg, centred forward")
      ->capture_default_str();
  cli.add_option("--max-range", f.laser.max_range,
                 "m; a beam that hits nothing closer reports this (a no-return)")
      ->capture_default_str();
  cli.add_option("--range-noise", f.laser.range_noise, "sigma of the range noise, m")
      ->capture_default_str();
  cli.add_option("--dropout", f.laser.dropout, "probability per beam of a no-return")
      ->capture_default_str();
  cli.add_option("--odom-noise-xy", f.odometry.noise_xy, "odometry x/y sigma per metre, m/m")
      ->capture_default_str();
  cli.add_option("--odom-noise-theta", f.odometry.noise_theta,
                 "odometry heading sigma per radian turned, rad/rad")
      ->capture_default_str();
  cli.add_option("--odom-noise-theta-per-m", f.odometry.noise_theta_per_m,
                 "odometry heading sigma per metre driven, rad/m")
      ->capture_default_str();
  cli.add_option("--start-stamp", o.start_stamp,
                 "stamp (s) of sim time 0; default: the wall clock at start, whole seconds");
  cli.add_option("--duration", o.duration, "seconds of sim time; 0 = until SIGINT/SIGTERM")
      ->capture_default_str();
  app::add_dds_flags(cli, o.domain, o.profile, o.secure);
  cli.add_option("--wait-subscribers", o.wait_subscribers,
                 "before the first tick, wait until N scan readers are matched (summed over "
                 "the robots: a reader of every robot counts once per robot)")
      ->capture_default_str();
  cli.add_option("--wait-timeout", o.wait_timeout, "wait at most S seconds, then start anyway")
      ->capture_default_str();
  cli.add_option("--out-log", o.out_log,
                 "also write DIR/<id>.log (CARMEN ODOM + FLASER) and DIR/<id>.truth");
  cli.add_flag("--offline", o.offline,
               "no DDS: write --out-log as fast as possible for --duration s of sim time");
}

}  // namespace esfleet::sim
