#include "noisy_odometry.hpp"

#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "app/program.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/sim/log_writer.hpp"

namespace esfleet::bench {

void add_noisy_odometry_options(CLI::App& cmd, NoisyOdometryOptions& o) {
  cmd.add_option("--log", o.log, "CARMEN log whose odometry fields give the motion")->required();
  cmd.add_option("--out-dir", o.out_dir, "writes ROBOT_ID.log and ROBOT_ID.truth here")->required();
  cmd.add_option("--robot-id", o.robot_id, "file name of the outputs")->capture_default_str();
  cmd.add_option("--seed", o.seed, "noise seed")->capture_default_str();
  cmd.add_option("--distance-frac", o.noise.distance_frac,
                 "translation sigma per metre driven, per step")
      ->capture_default_str();
  cmd.add_option("--distance-base", o.noise.distance_base_m,
                 "translation sigma per moving step, metres")
      ->capture_default_str();
  cmd.add_option("--turn-frac", o.noise.turn_frac, "heading sigma per radian turned, per step")
      ->capture_default_str();
  cmd.add_option("--turn-base-deg", o.noise.turn_base_deg, "heading sigma per moving step, degrees")
      ->capture_default_str();
  cmd.add_option("--turn-per-m-deg", o.noise.turn_per_m_deg,
                 "heading sigma per metre driven, degrees")
      ->capture_default_str();
  cmd.add_option_function<std::string>(
         "--even-beams",
         [&o](const std::string& v) {
           o.reader.even_beams = v == "centered" ? EvenBeamConvention::kCentered
                                                 : EvenBeamConvention::kStartAtMinus90;
         },
         "beam angles of FLASER scans with an even beam count (as the leader's flag)")
      ->check(CLI::IsMember({"start", "centered"}))
      ->default_str("start");
  cmd.add_option("--no-return-range", o.reader.no_return_range,
                 "readings at or above this are no-returns, metres")
      ->capture_default_str();
  cmd.add_option("--json", o.json, "write the figures here too");
}

int run_noisy_odometry(const NoisyOdometryOptions& o) {
  try {
    o.noise.validate();
  } catch (const std::invalid_argument& e) {
    throw app::UsageError(e.what());
  }
  std::vector<LaserScan> scans;
  try {
    scans = read_carmen_log(o.log, o.reader);
  } catch (const std::exception& e) {
    throw app::UsageError(e.what());
  }
  std::vector<Pose2> source;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (!scans[i].odometry) {
      throw app::UsageError(o.log + ": scan " + std::to_string(i) + " has no odometry field");
    }
    source.push_back(*scans[i].odometry);
  }
  const std::vector<Pose2> noisy = noisy_odometry(source, o.noise, o.seed);
  std::filesystem::create_directories(o.out_dir);
  sim::RobotLogWriter writer(o.out_dir, o.robot_id);
  double distance = 0.0, turned = 0.0;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    double speed = 0.0, turn_rate = 0.0;
    if (i > 0) {
      const Pose2 step = source[i].relative_to(source[i - 1]);
      const double dt = scans[i].stamp - scans[i - 1].stamp;
      distance += std::hypot(step.x, step.y);
      turned += std::abs(step.theta);
      if (dt > 0) {
        speed = std::hypot(step.x, step.y) / dt;
        turn_rate = step.theta / dt;
      }
    }
    LaserScan scan = scans[i];
    scan.odometry = noisy[i];
    writer.write(scan, source[i], speed, turn_rate);
  }
  writer.flush();
  // Drift: the noisy odometry's end pose seen against the source's, both from the start.
  const Pose2 end_error = noisy.back().relative_to(source.back());
  const double drift_m = std::hypot(end_error.x, end_error.y);
  spdlog::info(
      "{} scans, {:.1f} m driven, {:.0f} deg turned; noisy odometry ends {:.2f} m and {:.1f} deg "
      "off ({:.1f} % of the distance); wrote {} and {}",
      scans.size(), distance, rad_to_deg(turned), drift_m, rad_to_deg(std::abs(end_error.theta)),
      distance > 0 ? 100.0 * drift_m / distance : 0.0, writer.log_path(), writer.truth_path());
  if (!o.json.empty()) {
    const nlohmann::json j = {{"log", o.log},
                              {"seed", o.seed},
                              {"scans", scans.size()},
                              {"distance_m", distance},
                              {"turned_deg", rad_to_deg(turned)},
                              {"end_drift_m", drift_m},
                              {"end_drift_deg", rad_to_deg(std::abs(end_error.theta))},
                              {"out_log", writer.log_path()}};
    write_file_atomically(o.json, j.dump(2) + "\n");
  }
  return app::kExitOk;
}

}  // namespace esfleet::bench
