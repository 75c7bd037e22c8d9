#include "esfleet/core/slam.hpp"

#include <cmath>
#include <stdexcept>

#include "esfleet/core/scan_points.hpp"

namespace esfleet {

void SlamConfig::validate() const {
  map.validate();
  update.validate();
  es.validate();
  if (!(min_range >= 0.0f)) throw std::invalid_argument("slam.min_range must be >= 0");
  if (!(max_range >= 0.0f)) throw std::invalid_argument("slam.max_range must be >= 0 (0 = all)");
  if (!(init_sigma_xy >= 0.0) || !std::isfinite(init_sigma_xy)) {
    throw std::invalid_argument("slam.init_sigma_xy must be >= 0");
  }
  if (!(init_sigma_theta_deg >= 0.0) || !std::isfinite(init_sigma_theta_deg)) {
    throw std::invalid_argument("slam.init_sigma_theta_deg must be >= 0");
  }
}

SlamConfig SlamConfig::paper() {
  SlamConfig c;
  c.prediction = MotionPrediction::kPreviousPose;
  c.use_odometry = false;
  c.use_penalty = true;
  return c;
}

Slam::Slam(SlamConfig config)
    : config_(config), map_(config.map), es_(config.es), rng_(config.seed) {
  config_.validate();
}

Pose2 Slam::predict(const LaserScan& scan) const {
  const Pose2& prev = trajectory_.back().pose;
  if (config_.use_odometry && scan.odometry && last_odometry_) {
    return prev.compose(scan.odometry->relative_to(*last_odometry_));
  }
  if (config_.prediction == MotionPrediction::kConstantVelocity && trajectory_.size() >= 2) {
    const TimedPose& a = trajectory_[trajectory_.size() - 2];
    const TimedPose& b = trajectory_.back();
    const Pose2 motion = b.pose.relative_to(a.pose);
    const double dt_prev = b.stamp - a.stamp;
    const double dt = scan.stamp - b.stamp;
    // Scale the last motion by the time ratio; fall back to one step when stamps are odd.
    double k = (dt_prev > 1e-6 && dt > 0.0) ? dt / dt_prev : 1.0;
    k = std::clamp(k, 0.0, 3.0);
    return prev.compose({motion.x * k, motion.y * k, motion.theta * k});
  }
  return prev;
}

SlamStep Slam::process(const LaserScan& scan) {
  const ScanPoints points = prepare_scan(scan, config_.min_range, config_.max_range);
  SlamStep step;
  if (trajectory_.empty()) {
    step.inserted = true;
    step.update = update_map(map_, points, step.pose, config_.update);
  } else {
    step.predicted = predict(scan);
    const FitnessEvaluator evaluator(map_, points, config_.use_penalty);
    const auto initial = make_initial_population(config_.es.mu, config_.init_sigma_xy,
                                                 deg_to_rad(config_.init_sigma_theta_deg), rng_);
    const EsResult r = es_.search(evaluator, step.predicted, initial, rng_);
    step.pose = r.pose;
    step.fitness = r.value;
    step.inserted = true;
    step.update = update_map(map_, points, step.pose, config_.update);
  }
  if (scan.odometry) last_odometry_ = scan.odometry;
  trajectory_.push_back({scan.stamp, step.pose});
  return step;
}

}  // namespace esfleet
