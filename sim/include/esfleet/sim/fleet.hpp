#pragma once
// The fleet simulator: N robots in one world, advanced together one sensor tick at a time.
// No DDS and no files here (the program publishes and writes); deterministic for a seed: tick k
// of a run gives the same poses and scans whatever the wall-clock timing of the ticks.
//
// Time: tick k (k = 1, 2, ...) is at sim time k / rate seconds; its stamp is start_stamp plus
// that. Each tick every robot moves for 1 / rate s, then takes one scan at its new true pose;
// the scan carries the odometry pose and the truth sample the same stamp.

#include <cstdint>
#include <string>
#include <vector>

#include "esfleet/core/laser_scan.hpp"
#include "esfleet/sim/laser_model.hpp"
#include "esfleet/sim/planner.hpp"
#include "esfleet/sim/robot.hpp"
#include "esfleet/sim/world.hpp"

namespace esfleet::sim {

struct FleetConfig {
  int robots = 1;                    ///< number of robots, [1, 1000]
  std::string id_prefix = "robot-";  ///< robot k (1..N) is <prefix><k>
  std::uint64_t seed = 1;            ///< everything random derives from it
  double rate = 5.0;                 ///< sensor ticks per second, (0, 100]
  double start_stamp = 0.0;          ///< stamp of sim time 0, seconds (finite, >= 0)
  MotionConfig motion;
  LaserConfig laser;
  OdometryConfig odometry;

  /// Throws std::invalid_argument naming the field (as its flag), also for the nested configs.
  void validate() const;
};

/// What one robot produced in one tick.
struct RobotSample {
  const Robot* robot = nullptr;
  TimedPose truth;  ///< true pose, stamp == scan.stamp
  LaserScan scan;   ///< with odometry set
};

class Fleet {
 public:
  /// Builds the planning grid and places the robots. Throws std::invalid_argument for a bad
  /// config and std::runtime_error if the world has no drivable space with the clearance.
  Fleet(const World& world, FleetConfig config);

  /// Advances every robot by one tick and returns their samples, in robot order. The returned
  /// reference is valid until the next call.
  const std::vector<RobotSample>& tick();

  const FleetConfig& config() const { return config_; }
  const std::vector<Robot>& robots() const { return robots_; }
  const PlanGrid& plan_grid() const { return grid_; }
  std::uint64_t ticks() const { return ticks_; }
  /// Sim time of the last tick, seconds.
  double sim_time() const { return static_cast<double>(ticks_) / config_.rate; }

 private:
  const World* world_;
  FleetConfig config_;
  PlanGrid grid_;
  std::vector<Robot> robots_;
  std::vector<Rng> laser_rngs_;
  std::vector<RobotSample> samples_;
  std::uint64_t ticks_ = 0;
};

}  // namespace esfleet::sim
