#include "esfleet/core/tracking.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

namespace esfleet {

namespace {

Correction correction_between(const Pose2& centre, const Pose2& p) {
  return {p.x - centre.x, p.y - centre.y, normalize_angle(p.theta - centre.theta)};
}

bool use_prior(const TrackingConfig& c) {
  return c.prior_sigma_xy > 0.0 && c.prior_sigma_theta_deg > 0.0;
}

/// A multi-modal motion prior: the best of the Gaussians around each hypothesis, i.e. the
/// Gaussian of the nearest one (one exp per call; a NaN distance counts as no hypothesis).
float prior(const TrackingConfig& c, const Pose2& p, const std::vector<Pose2>& hypotheses) {
  const double sxy = c.prior_sigma_xy;
  const double sth = deg_to_rad(c.prior_sigma_theta_deg);
  double nearest = std::numeric_limits<double>::infinity();
  for (const Pose2& h : hypotheses) {
    const double dx = (p.x - h.x) / sxy, dy = (p.y - h.y) / sxy;
    const double dt = normalize_angle(p.theta - h.theta) / sth;
    nearest = std::min(nearest, dx * dx + dy * dy + dt * dt);
  }
  return static_cast<float>(std::exp(-0.5 * nearest));
}

EsResult search(const TrackingConfig& c, const EvolutionStrategy& es, Rng& rng, const GridMap& map,
                const ScanPoints& points, const Pose2& centre, const std::vector<Pose2>& hypotheses,
                const std::vector<Pose2>& prior_hypotheses) {
  std::vector<Correction> extra;
  for (std::size_t h = 1; h < hypotheses.size(); ++h) {
    extra.push_back(correction_between(centre, hypotheses[h]));
  }
  const auto initial = make_initial_population(c.es.mu, c.init_sigma_xy,
                                               deg_to_rad(c.init_sigma_theta_deg), rng, extra);
  const FitnessOptions options = slam_fitness_options(c, c.interpolation == Interpolation::kAll);
  // Thinned, the ES scores about half the end points of a 0.5 deg laser indoors; the value
  // reported is over every end point, as without thinning.
  const bool thin = c.search_point_spacing > 0.0;
  const ScanPoints thinned = thin ? thin_scan(points, c.search_point_spacing) : ScanPoints{};
  const FitnessEvaluator eval(map, thin ? thinned : points, options);
  EsResult r;
  if (use_prior(c)) {
    r = es.search_with(
        [&](const Pose2& p) { return eval.fitness(p) * prior(c, p, prior_hypotheses); }, centre,
        initial, rng);
  } else {
    r = es.search_with([&](const Pose2& p) { return eval.fitness(p); }, centre, initial, rng);
  }
  r.value = thin ? FitnessEvaluator(map, points, options).evaluate(r.pose) : eval.evaluate(r.pose);
  return r;
}

/// `eval`: every end point, interpolated unless Interpolation::kNone.
EsResult polish(const TrackingConfig& c, const FitnessEvaluator& eval, const Pose2& start,
                const std::vector<Pose2>& hypotheses) {
  const bool with_prior = use_prior(c);
  EsResult r = refine_pose_with(
      [&](const Pose2& p) {
        return eval.fitness(p) * (with_prior ? prior(c, p, hypotheses) : 1.0f);
      },
      start, 0.02, deg_to_rad(0.5), 0.001);
  r.value = eval.evaluate(r.pose);
  return r;
}

/// The finite-difference step of the fitness's curvature (below a 0.05 m cell: the bilinear
/// fitness is smooth at that scale, and a wall's end points stay on the wall's slope).
constexpr double kHoldStep = 0.03;

/// TrackingConfig::motion_hold: `found` moved along the flattest direction onto the nearest
/// motion hypothesis, or nothing when the map constrains that direction too (ratio above
/// motion_hold_ratio) or the fitness there drops more than allowed.
std::optional<Pose2> hold_along_motion(const TrackingConfig& c, const FitnessEvaluator& eval,
                                       const Pose2& found, const std::vector<Pose2>& hypotheses) {
  if (!(c.motion_hold > 0.0) || hypotheses.empty()) return std::nullopt;
  const float f0 = eval.fitness(found);
  if (!(f0 > 0.0f)) return std::nullopt;
  const Flattest flat = flattest_direction(eval, found, f0, kHoldStep);
  if (flat.ratio > c.motion_hold_ratio) return std::nullopt;
  const auto nearest =
      std::min_element(hypotheses.begin(), hypotheses.end(), [&](const Pose2& p, const Pose2& q) {
        return std::hypot(p.x - found.x, p.y - found.y) < std::hypot(q.x - found.x, q.y - found.y);
      });
  const double s = flat.vx * (nearest->x - found.x) + flat.vy * (nearest->y - found.y);
  const Pose2 held{found.x + s * flat.vx, found.y + s * flat.vy, found.theta};
  if (eval.fitness(held) < static_cast<float>(1.0 - c.motion_hold) * f0) return std::nullopt;
  return held;
}

}  // namespace

void TrackingConfig::validate() const {
  es.validate();
  auto check = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(what);
  };
  check(min_range >= 0.0f, "slam.min_range must be >= 0");
  check(max_range >= 0.0f, "slam.max_range must be >= 0 (0 = all)");
  check(init_sigma_xy >= 0.0 && std::isfinite(init_sigma_xy), "slam.init_sigma_xy must be >= 0");
  check(init_sigma_theta_deg >= 0.0 && std::isfinite(init_sigma_theta_deg),
        "slam.init_sigma_theta must be >= 0");
  check(search_point_spacing >= 0.0 && std::isfinite(search_point_spacing),
        "slam.search_point_spacing must be >= 0 (0 = every end point)");
  check(prior_sigma_xy >= 0.0 && prior_sigma_theta_deg >= 0.0,
        "slam.prior_sigma_xy and prior_sigma_theta must be >= 0 (0 = no prior)");
  check(motion_hold >= 0.0 && motion_hold < 1.0, "slam.motion_hold must be in [0, 1)");
  check(motion_hold_ratio >= 0.0 && motion_hold_ratio <= 1.0,
        "slam.motion_hold_ratio must be in [0, 1]");
}

FitnessOptions slam_fitness_options(const TrackingConfig& config, bool interpolate) {
  FitnessOptions o;
  o.use_penalty = config.use_penalty;
  o.interpolate = interpolate;
  return o;
}

ScanPoints prepare_scan(const LaserScan& scan, const TrackingConfig& config) {
  return prepare_scan(scan, config.min_range, config.max_range);
}

double velocity_scale(const TimedPose& a, const TimedPose& b, double stamp) {
  const double dt_prev = b.stamp - a.stamp;
  const double dt = stamp - b.stamp;
  return std::clamp((dt_prev > 1e-6 && dt > 0.0) ? dt / dt_prev : 1.0, 0.0, 3.0);
}

Pose2 constant_velocity(const TimedPose& a, const TimedPose& b, double stamp) {
  const Pose2 delta = b.pose.relative_to(a.pose);
  const double k = velocity_scale(a, b, stamp);
  return b.pose.compose({delta.x * k, delta.y * k, delta.theta * k});
}

Pose2 predict_pose(const TrackingConfig& config, const MotionState& motion, const LaserScan& scan,
                   std::vector<Pose2>* alternatives) {
  const Pose2& prev = motion.last.pose;
  std::optional<Pose2> odom, velocity, step;
  if (config.use_odometry && scan.odometry && motion.odometry) {
    odom = prev.compose(scan.odometry->relative_to(*motion.odometry));
  }
  if (motion.previous) {
    // The last motion scaled by the time ratio (one step when stamps are odd).
    velocity = constant_velocity(*motion.previous, motion.last, scan.stamp);
    // Log stamps can jitter while the robot moves a steady distance per scan (fr079: the time
    // ratio is off by more than 1.5x for 43 % of scans, the motion ratio stays near 1), so the
    // unscaled last step is a hypothesis of its own when the two differ.
    if (std::abs(velocity_scale(*motion.previous, motion.last, scan.stamp) - 1.0) > 0.2) {
      step = prev.compose(motion.last.pose.relative_to(motion.previous->pose));
    }
  }
  Pose2 centre = prev;
  if (odom) {
    centre = *odom;
  } else if (config.prediction == MotionPrediction::kConstantVelocity && velocity) {
    centre = *velocity;
  }
  if (alternatives != nullptr) {
    // With odometry the previous pose is a poor hypothesis: in a corridor it fits as well as
    // the true pose and would let the search stop the robot.
    if (!odom) alternatives->push_back(prev);
    if (velocity) alternatives->push_back(*velocity);
    if (step) alternatives->push_back(*step);
    if (odom) alternatives->push_back(*odom);
    if (!odom && config.turn_hypotheses) {
      // Laser only, turning: the robot may speed up, slow down or reverse its turn (S-curves
      // reverse at 8 deg/scan on fr079, so constant velocity is then 16 deg off). Add the
      // constant-velocity pose turned by +-1 and +-2 times the last turn.
      for (const auto& base : {velocity, step}) {
        if (!base) continue;
        const double turn = normalize_angle(base->theta - prev.theta);
        if (std::abs(turn) <= deg_to_rad(1.0)) continue;
        for (const double f : {-2.0, -1.0, 1.0, 2.0}) {
          alternatives->push_back({base->x, base->y, normalize_angle(base->theta + f * turn)});
        }
      }
    }
  }
  return centre;
}

TrackResult track_scan(const TrackingConfig& config, const EvolutionStrategy& es, Rng& rng,
                       const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                       const MotionState& motion) {
  TrackResult out;
  std::vector<Pose2> alternatives;
  out.predicted = predict_pose(config, motion, scan, &alternatives);
  const double inv_cell = 1.0 / map.cell_size();
  if (beyond_any_map(out.predicted.x * inv_cell, out.predicted.y * inv_cell) && motion.odometry) {
    // An odometry step to where no map reaches (a broken or hostile message: the converters
    // check only that it is finite) is not followed: predicted without the odometry.
    MotionState without = motion;
    without.odometry.reset();
    alternatives.clear();
    out.predicted = predict_pose(config, without, scan, &alternatives);
  }
  // Hypotheses: the centre first, then the other motion hypotheses when switched on.
  std::vector<Pose2> hypotheses{out.predicted};
  if (config.motion_hypotheses) {
    hypotheses.insert(hypotheses.end(), alternatives.begin(), alternatives.end());
  }
  // The prior's hypotheses: laser only, "the robot stopped" (the previous pose) stays in the
  // population but gets no prior weight while another hypothesis says it moves: in a
  // featureless corridor it would otherwise hold the robot back.
  std::vector<Pose2> prior_hypotheses;
  const Pose2& last = motion.last.pose;
  for (const Pose2& h : hypotheses) {
    if (config.prior_on_stop || config.use_odometry || !(h == last)) {
      prior_hypotheses.push_back(h);
    }
  }
  if (prior_hypotheses.empty()) prior_hypotheses = hypotheses;
  out.result = search(config, es, rng, map, points, out.predicted, hypotheses, prior_hypotheses);
  if (!config.refine && !(config.motion_hold > 0.0)) return out;
  // The polish and the hold score every end point, interpolated unless switched off.
  const FitnessEvaluator fine(
      map, points, slam_fitness_options(config, config.interpolation != Interpolation::kNone));
  if (config.refine) out.result = polish(config, fine, out.result.pose, prior_hypotheses);
  if (config.motion_hold > 0.0) {
    if (const auto held = hold_along_motion(config, fine, out.result.pose, prior_hypotheses)) {
      out.result.pose = *held;
      out.result.value = fine.evaluate(*held);
    }
  }
  return out;
}

}  // namespace esfleet
