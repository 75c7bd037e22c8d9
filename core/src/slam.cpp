#include "esfleet/core/slam.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace esfleet {

void SlamConfig::validate() const {
  map.validate();
  update.validate();
  es.validate();
  auto check = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(what);
  };
  check(min_range >= 0.0f, "slam.min_range must be >= 0");
  check(max_range >= 0.0f, "slam.max_range must be >= 0 (0 = all)");
  check(init_sigma_xy >= 0.0 && std::isfinite(init_sigma_xy), "slam.init_sigma_xy must be >= 0");
  check(init_sigma_theta_deg >= 0.0 && std::isfinite(init_sigma_theta_deg),
        "slam.init_sigma_theta must be >= 0");
  check(prior_sigma_xy >= 0.0 && prior_sigma_theta_deg >= 0.0,
        "slam.prior_sigma_xy and prior_sigma_theta must be >= 0 (0 = no prior)");
  check(insert_min_travel >= 0.0 && insert_min_turn_deg >= 0.0,
        "slam.insert_min_travel and insert_min_turn must be >= 0");
  check(key_sigma_xy > 0.0 && key_sigma_theta_deg > 0.0,
        "slam.key_sigma_xy and key_sigma_theta must be > 0");
  if (loop.enabled) loop.validate();
}

SlamConfig SlamConfig::paper() {
  SlamConfig c;
  c.prediction = MotionPrediction::kPreviousPose;
  c.use_odometry = false;
  c.use_penalty = true;
  c.init_sigma_xy = 0.05;
  c.init_sigma_theta_deg = 2.0;
  c.motion_hypotheses = false;
  c.turn_hypotheses = false;
  c.interpolation = Interpolation::kNone;
  c.refine = false;
  c.prior_sigma_xy = 0.0;
  c.prior_sigma_theta_deg = 0.0;
  c.insert_min_travel = 0.0;
  c.insert_min_turn_deg = 0.0;
  c.loop.enabled = false;
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
  std::optional<Pose2> odom, velocity, step;
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
    // Log stamps can jitter while the robot moves a steady distance per scan (fr079: the time
    // ratio is off by more than 1.5x for 43 % of scans, the motion ratio stays near 1), so the
    // unscaled last step is a hypothesis of its own when the two differ.
    if (std::abs(k - 1.0) > 0.2) step = prev.compose(motion);
  }
  Pose2 centre = prev;
  if (odom) {
    centre = *odom;
  } else if (config_.prediction == MotionPrediction::kConstantVelocity && velocity) {
    centre = *velocity;
  }
  if (alternatives != nullptr) {
    // With odometry the previous pose is a poor hypothesis: in a corridor it fits as well as
    // the true pose and would let the search stop the robot.
    if (!odom) alternatives->push_back(prev);
    if (velocity) alternatives->push_back(*velocity);
    if (step) alternatives->push_back(*step);
    if (odom) alternatives->push_back(*odom);
    if (!odom && config_.turn_hypotheses) {
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

FitnessOptions Slam::fitness_options(bool interpolate) const {
  FitnessOptions o;
  o.use_penalty = config_.use_penalty;
  o.interpolate = interpolate;
  return o;
}

float Slam::prior(const Pose2& p, const std::vector<Pose2>& hypotheses) const {
  // A multi-modal motion prior: the best of the Gaussians around each hypothesis.
  const double sxy = config_.prior_sigma_xy;
  const double sth = deg_to_rad(config_.prior_sigma_theta_deg);
  double best = 0.0;
  for (const Pose2& h : hypotheses) {
    const double dx = (p.x - h.x) / sxy, dy = (p.y - h.y) / sxy;
    const double dt = normalize_angle(p.theta - h.theta) / sth;
    best = std::max(best, std::exp(-0.5 * (dx * dx + dy * dy + dt * dt)));
  }
  return static_cast<float>(best);
}

EsResult Slam::search(const ScanPoints& points, const Pose2& centre,
                      const std::vector<Pose2>& hypotheses,
                      const std::vector<Pose2>& prior_hypotheses) {
  std::vector<Correction> extra;
  for (std::size_t h = 1; h < hypotheses.size(); ++h) {
    extra.push_back(correction_between(centre, hypotheses[h]));
  }
  const auto initial = make_initial_population(
      config_.es.mu, config_.init_sigma_xy, deg_to_rad(config_.init_sigma_theta_deg), rng_, extra);
  const FitnessEvaluator eval(map_, points,
                              fitness_options(config_.interpolation == Interpolation::kAll));
  if (!use_prior()) return es_.search(eval, centre, initial, rng_);
  EsResult r =
      es_.search_with([&](const Pose2& p) { return eval.fitness(p) * prior(p, prior_hypotheses); },
                      centre, initial, rng_);
  r.value = eval.evaluate(r.pose);
  return r;
}

EsResult Slam::polish(const ScanPoints& points, const Pose2& start,
                      const std::vector<Pose2>& hypotheses) const {
  const FitnessEvaluator eval(map_, points,
                              fitness_options(config_.interpolation != Interpolation::kNone));
  const bool with_prior = use_prior();
  EsResult r = refine_pose_with(
      [&](const Pose2& p) { return eval.fitness(p) * (with_prior ? prior(p, hypotheses) : 1.0f); },
      start, 0.02, deg_to_rad(0.5), 0.001);
  r.value = eval.evaluate(r.pose);
  return r;
}

namespace {
using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
}  // namespace

SlamStep Slam::process(const LaserScan& scan) {
  const ScanPoints points = prepare_scan(scan, config_.min_range, config_.max_range);
  SlamStep step;
  bool insert = true;
  if (!trajectory_.empty()) {
    std::vector<Pose2> alternatives;
    step.predicted = predict(scan, &alternatives);
    // Hypotheses: the centre first, then the other motion hypotheses when switched on.
    std::vector<Pose2> hypotheses{step.predicted};
    if (config_.motion_hypotheses) {
      hypotheses.insert(hypotheses.end(), alternatives.begin(), alternatives.end());
    }
    const auto t_search = Clock::now();
    // The prior's hypotheses: laser only, "the robot stopped" (the previous pose) stays in the
    // population but gets no prior weight while another hypothesis says it moves: in a
    // featureless corridor it would otherwise hold the robot back.
    std::vector<Pose2> prior_hypotheses;
    const Pose2& last = trajectory_.back().pose;
    for (const Pose2& h : hypotheses) {
      if (config_.prior_on_stop || config_.use_odometry || !(h == last)) {
        prior_hypotheses.push_back(h);
      }
    }
    if (prior_hypotheses.empty()) prior_hypotheses = hypotheses;
    EsResult r = search(points, step.predicted, hypotheses, prior_hypotheses);
    if (config_.refine) r = polish(points, r.pose, prior_hypotheses);
    step.pose = r.pose;
    step.fitness = r.value;
    step.search_ms = ms_since(t_search);
    if (last_inserted_ && (config_.insert_min_travel > 0.0 || config_.insert_min_turn_deg > 0.0)) {
      const Pose2 d = step.pose.relative_to(*last_inserted_);
      insert = std::hypot(d.x, d.y) >= config_.insert_min_travel ||
               std::abs(d.theta) >= deg_to_rad(config_.insert_min_turn_deg);
    }
    const Pose2& prev = trajectory_.back().pose;
    path_length_ += std::hypot(step.pose.x - prev.x, step.pose.y - prev.y);
  }
  if (insert) {
    step.inserted = true;
    const auto t_update = Clock::now();
    step.update = update_map(map_, points, step.pose, config_.update);
    step.update_ms = ms_since(t_update);
    last_inserted_ = step.pose;
  }
  if (scan.odometry) last_odometry_ = scan.odometry;
  trajectory_.push_back({scan.stamp, step.pose});
  if (config_.loop.enabled) {
    if (insert) {
      anchors_.emplace_back(keys_.size(), Pose2{});
      const auto t_loop = Clock::now();
      step.loop_closed = add_key_scan(points, step.pose, scan.stamp);
      step.loop_ms = ms_since(t_loop);
      if (step.loop_closed) step.pose = trajectory_.back().pose;
    } else {
      const std::size_t k = keys_.size() - 1;
      anchors_.emplace_back(k, step.pose.relative_to(graph_.node(k)));
    }
  }
  return step;
}

bool Slam::add_key_scan(const ScanPoints& points, const Pose2& pose, double stamp) {
  KeyScan key;
  key.stamp = stamp;
  key.points = points;
  key.mapped_pose = pose;
  key.path_length = path_length_;
  const std::size_t k = graph_.add_node(pose);
  keys_.push_back(std::move(key));
  if (k > 0) {
    PoseGraphEdge e;
    e.from = k - 1;
    e.to = k;
    e.measurement = pose.relative_to(graph_.node(k - 1));
    e.info_xy = 1.0 / (config_.key_sigma_xy * config_.key_sigma_xy);
    e.info_theta = 1.0 / std::pow(deg_to_rad(config_.key_sigma_theta_deg), 2);
    graph_.add_edge(e);
  }
  if (k == 0 || k % static_cast<std::size_t>(config_.loop.every) != 0) return false;
  const auto match = find_loop_closure(
      keys_, graph_.nodes(), points, pose, path_length_, config_.loop, config_.map, config_.update,
      fitness_options(config_.interpolation != Interpolation::kNone));
  if (!match) return false;
  PoseGraphEdge e;
  e.from = match->anchor;
  e.to = k;
  e.measurement = match->relative;
  e.info_xy = 1.0 / (config_.loop.sigma_xy * config_.loop.sigma_xy);
  e.info_theta = 1.0 / std::pow(deg_to_rad(config_.loop.sigma_theta_deg), 2);
  e.huber = config_.loop.huber;
  std::vector<Pose2> before = graph_.nodes();
  const double cost_before = graph_.cost();
  graph_.add_edge(e);
  graph_.optimize(10);
  // Accept only if the graph can take the closure without straining: the whole graph's cost
  // (the new edge included) may grow by at most max_chi2.
  if (graph_.cost() - cost_before > config_.loop.max_chi2) {
    // The graph cannot agree with this closure: drop it.
    graph_.pop_edge();
    graph_.set_nodes(std::move(before));
    ++loop_rejected_;
    return false;
  }
  ++loop_closures_;
  last_loop_ = LoopEvent{k, match->anchor, match->pose.relative_to(pose), match->value.agreement(),
                         match->ambiguity};
  apply_graph();
  return true;
}

void Slam::apply_graph() {
  const double move_xy = config_.loop.move_min_xy;
  const double move_theta = deg_to_rad(config_.loop.move_min_theta_deg);
  bool changed = false;
  for (std::size_t k = 0; k < keys_.size(); ++k) {
    KeyScan& key = keys_[k];
    const Pose2& now = graph_.node(k);
    if (std::hypot(now.x - key.mapped_pose.x, now.y - key.mapped_pose.y) < move_xy &&
        std::abs(normalize_angle(now.theta - key.mapped_pose.theta)) < move_theta) {
      continue;
    }
    update_map(map_, key.points, key.mapped_pose, config_.update, /*remove=*/true, false);
    update_map(map_, key.points, now, config_.update, false, false);
    key.mapped_pose = now;
    changed = true;
  }
  if (changed) map_.commit_update();
  for (std::size_t t = 0; t < trajectory_.size(); ++t) {
    const auto& [k, rel] = anchors_[t];
    trajectory_[t].pose = graph_.node(k).compose(rel);
  }
  last_inserted_ = graph_.node(keys_.size() - 1);
}

}  // namespace esfleet
