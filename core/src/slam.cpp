#include "esfleet/core/slam.hpp"

#include <cmath>
#include <stdexcept>

#include "esfleet/core/scan_points.hpp"
#include <string>

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
  if (coarse_level < 0 || coarse_level > map.pyramid_levels) {
    throw std::invalid_argument("slam.coarse_level must be in [0, map.pyramid_levels = " +
                                std::to_string(map.pyramid_levels) + "]");
  }
  if (coarse_iterations < 0) throw std::invalid_argument("slam.coarse_iterations must be >= 0");
  if (coarse_stride < 1) throw std::invalid_argument("slam.coarse_stride must be >= 1");
}

SlamConfig SlamConfig::paper() {
  SlamConfig c;
  c.prediction = MotionPrediction::kPreviousPose;
  c.use_odometry = false;
  c.use_penalty = true;
  c.motion_hypotheses = false;
  c.coarse_level = 0;
  c.map.pyramid_levels = 0;
  return c;
}

Slam::Slam(SlamConfig config)
    : config_(config), map_(config.map), es_(config.es), rng_(config.seed) {
  config_.validate();
}

namespace {
Correction correction_between(const Pose2& centre, const Pose2& p) {
  return {p.x - centre.x, p.y - centre.y, normalize_angle(p.theta - centre.theta)};
}
}  // namespace

Pose2 Slam::predict(const LaserScan& scan, std::vector<Pose2>* alternatives) const {
  const Pose2& prev = trajectory_.back().pose;
  std::optional<Pose2> odom, velocity;
  if (config_.use_odometry && scan.odometry && last_odometry_) {
    odom = prev.compose(scan.odometry->relative_to(*last_odometry_));
  }
  if (trajectory_.size() >= 2) {
    const TimedPose& a = trajectory_[trajectory_.size() - 2];
    const TimedPose& b = trajectory_.back();
    const Pose2 motion = b.pose.relative_to(a.pose);
    const double dt_prev = b.stamp - a.stamp;
    const double dt = scan.stamp - b.stamp;
    // Scale the last motion by the time ratio; fall back to one step when stamps are odd.
    double k = (dt_prev > 1e-6 && dt > 0.0) ? dt / dt_prev : 1.0;
    k = std::clamp(k, 0.0, 3.0);
    velocity = prev.compose({motion.x * k, motion.y * k, motion.theta * k});
  }
  Pose2 centre = prev;
  if (odom) {
    centre = *odom;
  } else if (config_.prediction == MotionPrediction::kConstantVelocity && velocity) {
    centre = *velocity;
  }
  if (alternatives != nullptr) {
    alternatives->push_back(prev);
    if (velocity) alternatives->push_back(*velocity);
    if (odom) alternatives->push_back(*odom);
  }
  return centre;
}

EsResult Slam::search(const ScanPoints& points, const Pose2& centre,
                      const std::vector<Pose2>& alternatives) {
  std::vector<Correction> extra;
  if (config_.motion_hypotheses) {
    for (const Pose2& p : alternatives) extra.push_back(correction_between(centre, p));
  }
  const FitnessEvaluator fine(map_, points, config_.use_penalty);
  if (config_.coarse_level <= 0) {
    return es_.search(fine, centre,
                      make_initial_population(config_.es.mu, config_.init_sigma_xy,
                                              deg_to_rad(config_.init_sigma_theta_deg), rng_,
                                              extra),
                      rng_);
  }
  const FitnessEvaluator coarse(map_, points, config_.use_penalty, config_.coarse_level,
                                config_.coarse_stride);
  const int coarse_iterations = std::min(config_.coarse_iterations, config_.es.iterations);
  const EsResult rc =
      es_.search(coarse, centre,
                 make_initial_population(config_.es.mu, config_.coarse_sigma_xy,
                                         deg_to_rad(config_.coarse_sigma_theta_deg), rng_, extra),
                 rng_, coarse_iterations);
  return es_.search(fine, centre, rc.population, rng_, config_.es.iterations - coarse_iterations);
}

SlamStep Slam::process(const LaserScan& scan) {
  const ScanPoints points = prepare_scan(scan, config_.min_range, config_.max_range);
  SlamStep step;
  if (trajectory_.empty()) {
    step.inserted = true;
    step.update = update_map(map_, points, step.pose, config_.update);
  } else {
    std::vector<Pose2> alternatives;
    step.predicted = predict(scan, &alternatives);
    const EsResult r = search(points, step.predicted, alternatives);
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
