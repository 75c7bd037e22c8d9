#pragma once
// One simulated robot: a unicycle that drives to random goals along A* paths, and its noisy
// wheel odometry.
//
// Motion. The robot starts at the centre of a random open cell of the largest connected
// component of the planning grid (small pockets cut off by the clearance are never used), with a
// random heading, and from then on only picks goals in that component (at least 1 m away when
// possible). It follows the waypoints of the shortened A* path with a simple controller, in
// sub-steps of at most 20 ms: heading error e to the next waypoint; turn rate = 3/s * e, clamped
// to the maximum turn rate; when |e| >= 0.5 rad (~29 deg) it turns in place, below that it
// drives at max speed * (1 - |e| / 0.5 rad), never past the waypoint. A waypoint is reached
// within 5 cm; at the last one the robot picks a new goal at once.
// The planning grid uses the clearance plus a 5 cm margin, so the small departures of the
// controller from the straight segments stay in drivable space. As a guarantee, a sub-step
// whose end position would not be drivable (free with the configured clearance) does not
// translate (it still turns); the robot then replans. Every true pose is therefore drivable.
// Robots neither see nor avoid each other (nor do they appear in each other's scans).
//
// Odometry. The odometry frame starts at (0, 0, 0) at the robot's start pose, as a real robot's
// wheel odometry does. Each call of step() (one sensor tick) takes the true motion increment
// (x, y, theta in the robot frame at the tick's start) and adds independent Gaussian noise with
// sigma_xy = noise_xy * d on x and y and sigma_theta = noise_theta * |dtheta| +
// noise_theta_per_m * d on theta (d = length of the increment), then composes it onto the
// odometry pose. With all three at zero the odometry increments equal the true ones.

#include <cstdint>
#include <string>
#include <vector>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/sim/planner.hpp"
#include "esfleet/sim/world.hpp"

namespace esfleet::sim {

struct MotionConfig {
  double speed = 0.5;           ///< maximum forward speed, m/s, (0, 5]
  double turn_rate_deg = 60.0;  ///< maximum turn rate, deg/s, (0, 720]
  double clearance = 0.35;      ///< least distance of a robot centre to non-free space, m, >= 0
  double plan_cell = 0.1;       ///< planning grid cell, m (rounded to whole world cells), > 0

  /// Throws std::invalid_argument naming the field (as its flag).
  void validate() const;
};

struct OdometryConfig {
  double noise_xy = 0.02;           ///< sigma of x and y per metre travelled (m/m), >= 0
  double noise_theta = 0.02;        ///< sigma of the heading per radian turned (rad/rad), >= 0
  double noise_theta_per_m = 0.01;  ///< sigma of the heading per metre travelled (rad/m), >= 0

  void validate() const;
};

/// Extra clearance (m) of the planning grid over MotionConfig::clearance (see the file comment).
inline constexpr double kPlanMargin = 0.05;

/// The planning grid robots of `world` use with `motion`. Throws std::runtime_error if no cell
/// is open (no drivable space with the clearance).
PlanGrid make_plan_grid(const World& world, const MotionConfig& motion);

class Robot {
 public:
  /// Places the robot at a random start (see the file comment) drawn from `seed`. `world` and
  /// `grid` must outlive the robot; `grid` must have an open cell.
  Robot(std::string id, const World& world, const PlanGrid& grid, MotionConfig motion,
        OdometryConfig odometry, std::uint64_t seed);

  /// Advances the true pose by `dt` seconds and the odometry by the noisy increment.
  void step(double dt);

  const std::string& id() const { return id_; }
  const Pose2& truth() const { return truth_; }
  const Pose2& odometry() const { return odometry_; }
  /// Forward speed (m/s) and turn rate (rad/s) of the last sub-step.
  double speed() const { return v_; }
  double turn_rate() const { return w_; }
  /// Goals reached so far.
  std::uint64_t goals_reached() const { return goals_reached_; }
  /// Metres driven (true motion).
  double distance() const { return distance_; }
  /// Sub-steps that did not translate because the end would not have been drivable.
  std::uint64_t blocked_steps() const { return blocked_steps_; }
  /// Times no path to any goal was found (the robot then waits a sub-step and tries again).
  std::uint64_t planning_failures() const { return planning_failures_; }
  /// Remaining waypoints (world frame), the last one the goal.
  const std::vector<Point2>& path() const { return path_; }

 private:
  void substep(double h);
  bool choose_goal();
  /// The open cell the robot plans from: its own, else the nearest open one of its component
  /// within a few cells; nullopt if none.
  std::optional<Cell> plan_start() const;
  void update_odometry(const Pose2& before);

  std::string id_;
  const World* world_;
  const PlanGrid* grid_;
  MotionConfig motion_;
  OdometryConfig odom_config_;
  Rng motion_rng_, odom_rng_;
  int component_ = 0;
  Pose2 truth_, odometry_;
  std::vector<Point2> path_;
  std::size_t next_ = 0;  ///< index of the waypoint being driven to
  double v_ = 0.0, w_ = 0.0;
  std::uint64_t goals_reached_ = 0, blocked_steps_ = 0, planning_failures_ = 0;
  double distance_ = 0.0;
};

/// Seed of random stream `stream` of robot `index` under the run's `seed`: independent streams,
/// so e.g. changing the beam count does not change the trajectories.
std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t index, std::uint64_t stream);

}  // namespace esfleet::sim
