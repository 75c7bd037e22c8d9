#include "esfleet/sim/robot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

namespace esfleet::sim {
namespace {

constexpr double kMaxSubstep = 0.02;       ///< s
constexpr double kTurnGain = 3.0;          ///< turn rate per radian of heading error, 1/s
constexpr double kTurnInPlace = 0.5;       ///< rad: from this heading error on, turn in place
constexpr double kWaypointReached = 0.05;  ///< m
constexpr double kMinGoalDistance = 1.0;   ///< m
constexpr int kGoalAttempts = 20;
constexpr int kStartSearchRadius = 4;  ///< cells around the robot to find an open one

double clamp_abs(double v, double limit) { return std::clamp(v, -limit, limit); }

}  // namespace

void MotionConfig::validate() const {
  if (!(speed > 0.0 && speed <= 5.0)) throw std::invalid_argument("--speed must be in (0, 5]");
  if (!(turn_rate_deg > 0.0 && turn_rate_deg <= 720.0)) {
    throw std::invalid_argument("--turn-rate must be in (0, 720]");
  }
  if (!(clearance >= 0.0 && clearance <= 10.0)) {
    throw std::invalid_argument("--clearance must be in [0, 10]");
  }
  if (!(plan_cell > 0.0 && plan_cell <= 2.0)) {
    throw std::invalid_argument("--plan-cell must be in (0, 2]");
  }
}

void OdometryConfig::validate() const {
  auto check = [](double v, const char* flag) {
    if (!(v >= 0.0 && v <= 1.0))
      throw std::invalid_argument(std::string(flag) + " must be in [0, 1]");
  };
  check(noise_xy, "--odom-noise-xy");
  check(noise_theta, "--odom-noise-theta");
  check(noise_theta_per_m, "--odom-noise-theta-per-m");
}

PlanGrid make_plan_grid(const World& world, const MotionConfig& motion) {
  PlanGrid grid(world, motion.plan_cell, motion.clearance + kPlanMargin);
  if (grid.open_count() == 0) {
    char buf[128];
    std::snprintf(buf, sizeof buf,
                  "no drivable space with clearance %.3g m (+ %.3g m planning margin)",
                  motion.clearance, kPlanMargin);
    throw std::runtime_error(buf);
  }
  return grid;
}

std::uint64_t stream_seed(std::uint64_t seed, std::uint64_t index, std::uint64_t stream) {
  // Rng runs the value through splitmix64, so distinct inputs give unrelated streams.
  return seed * 0x9E3779B97F4A7C15ull + (index << 8) + stream;
}

Robot::Robot(std::string id, const World& world, const PlanGrid& grid, MotionConfig motion,
             OdometryConfig odometry, std::uint64_t seed)
    : id_(std::move(id)),
      world_(&world),
      grid_(&grid),
      motion_(motion),
      odom_config_(odometry),
      motion_rng_(stream_seed(seed, 0, 1)),
      odom_rng_(stream_seed(seed, 0, 2)) {
  const auto& cells = grid.component_cells(0);
  const Point2 p =
      grid.centre_of(cells[motion_rng_.below(static_cast<std::uint32_t>(cells.size()))]);
  truth_ = {p.x, p.y, normalize_angle(motion_rng_.uniform(-std::numbers::pi, std::numbers::pi))};
}

void Robot::step(double dt) {
  const Pose2 before = truth_;
  const int n = std::max(1, static_cast<int>(std::ceil(dt / kMaxSubstep - 1e-9)));
  for (int i = 0; i < n; ++i) substep(dt / n);
  update_odometry(before);
}

void Robot::update_odometry(const Pose2& before) {
  const Pose2 inc = truth_.relative_to(before);
  const double d = std::hypot(inc.x, inc.y);
  const double sxy = odom_config_.noise_xy * d;
  const double sth =
      odom_config_.noise_theta * std::abs(inc.theta) + odom_config_.noise_theta_per_m * d;
  // Draw always (even for zero sigma), so the stream does not depend on the motion.
  const double nx = odom_rng_.normal(), ny = odom_rng_.normal(), nt = odom_rng_.normal();
  const Pose2 noisy{inc.x + sxy * nx, inc.y + sxy * ny, inc.theta + sth * nt};
  odometry_ = odometry_.compose(noisy);
}

std::optional<Cell> Robot::plan_start() const {
  const Cell own = grid_->cell_at({truth_.x, truth_.y});
  if (grid_->component_of(own) == component_) return own;
  // Off the open cells (after a blocked step or a corner): nearest open cell of the component.
  for (int r = 1; r <= kStartSearchRadius; ++r) {
    std::optional<Cell> best;
    double best_d = 0.0;
    for (int dy = -r; dy <= r; ++dy) {
      for (int dx = -r; dx <= r; ++dx) {
        if (std::max(std::abs(dx), std::abs(dy)) != r) continue;
        const Cell c{own.x + dx, own.y + dy};
        if (grid_->component_of(c) != component_) continue;
        const Point2 p = grid_->centre_of(c);
        const double d = std::hypot(p.x - truth_.x, p.y - truth_.y);
        if (!best || d < best_d) {
          best = c;
          best_d = d;
        }
      }
    }
    if (best) return best;
  }
  return std::nullopt;
}

bool Robot::choose_goal() {
  path_.clear();
  next_ = 0;
  const auto start = plan_start();
  if (!start) return false;
  const auto& cells = grid_->component_cells(component_);
  for (int attempt = 0; attempt < kGoalAttempts; ++attempt) {
    const Cell goal = cells[motion_rng_.below(static_cast<std::uint32_t>(cells.size()))];
    const Point2 g = grid_->centre_of(goal);
    const bool last_try = attempt + 1 == kGoalAttempts;
    if (!last_try && std::hypot(g.x - truth_.x, g.y - truth_.y) < kMinGoalDistance) continue;
    auto path = grid_->plan(*start, goal);
    if (!path) continue;
    // Drive to the start cell's centre first when the robot is not in it.
    const Point2 s = grid_->centre_of(*start);
    if (!(grid_->cell_at({truth_.x, truth_.y}) == *start)) path->insert(path->begin(), s);
    if (path->empty()) path->push_back(s);
    path_ = std::move(*path);
    return true;
  }
  return false;
}

void Robot::substep(double h) {
  v_ = w_ = 0.0;
  if (next_ >= path_.size() && !choose_goal()) {
    ++planning_failures_;
    return;
  }
  const Point2 target = path_[next_];
  const double dist = std::hypot(target.x - truth_.x, target.y - truth_.y);
  if (dist < kWaypointReached) {
    if (++next_ >= path_.size()) ++goals_reached_;
    return;
  }
  const double turn_limit = deg_to_rad(motion_.turn_rate_deg);
  const double err =
      normalize_angle(std::atan2(target.y - truth_.y, target.x - truth_.x) - truth_.theta);
  double w = clamp_abs(kTurnGain * err, turn_limit);
  double v =
      std::abs(err) >= kTurnInPlace ? 0.0 : motion_.speed * (1.0 - std::abs(err) / kTurnInPlace);
  v = std::min(v, dist / h);

  // Exact unicycle arc over the sub-step: a chord of length v h sinc(w h / 2) in the direction
  // of the mean heading (stable for small w, unlike v / w (sin - sin)).
  Pose2 next = truth_;
  const double th = truth_.theta;
  const double half = w * h / 2.0;
  const double sinc = std::abs(half) > 1e-6 ? std::sin(half) / half : 1.0 - half * half / 6.0;
  next.x += v * h * sinc * std::cos(th + half);
  next.y += v * h * sinc * std::sin(th + half);
  next.theta = normalize_angle(th + w * h);
  if (v > 0.0 && !world_->drivable(next.x, next.y, motion_.clearance)) {
    // Safety net: turn only, and replan from here at the next sub-step.
    next.x = truth_.x;
    next.y = truth_.y;
    v = 0.0;
    ++blocked_steps_;
    path_.clear();
    next_ = 0;
  }
  distance_ += std::hypot(next.x - truth_.x, next.y - truth_.y);
  truth_ = next;
  v_ = v;
  w_ = w;
}

}  // namespace esfleet::sim
