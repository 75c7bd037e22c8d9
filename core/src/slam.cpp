#include "esfleet/core/slam.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include <string>
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
  if (coarse_level < 0 || coarse_level > map.pyramid_levels) {
    throw std::invalid_argument("slam.coarse_level must be in [0, map.pyramid_levels = " +
                                std::to_string(map.pyramid_levels) + "]");
  }
  if (loop.enabled) loop.validate();
  if (!(key_sigma_xy > 0.0) || !(key_sigma_theta_deg > 0.0)) {
    throw std::invalid_argument("slam.key_sigma_xy and key_sigma_theta_deg must be > 0");
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
    // With odometry the previous pose is a poor hypothesis: in a corridor it fits as well as
    // the true pose and would let the search stop the robot.
    if (!odom) alternatives->push_back(prev);
    if (velocity) alternatives->push_back(*velocity);
    if (odom) alternatives->push_back(*odom);
  }
  return centre;
}

FitnessOptions Slam::fitness_options(int level) const {
  FitnessOptions o;
  o.use_penalty = config_.use_penalty;
  o.level = level;
  o.stride = level > 0 ? config_.coarse_stride : 1;
  o.interpolate = level == 0 && config_.interpolate;
  return o;
}

float Slam::prior(const Pose2& p, const std::vector<Pose2>& hypotheses) const {
  // A flat-topped, multi-modal motion prior: the best of Gaussians around each hypothesis.
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
                      const std::vector<Pose2>& alternatives, double sigma_scale) {
  std::vector<Correction> extra;
  if (config_.motion_hypotheses) {
    for (const Pose2& p : alternatives) extra.push_back(correction_between(centre, p));
  }
  std::vector<Pose2> hypotheses{centre};
  if (config_.motion_hypotheses && !config_.prior_centre_only) {
    hypotheses.insert(hypotheses.end(), alternatives.begin(), alternatives.end());
  }
  const bool use_prior = config_.prior_sigma_xy > 0.0 && config_.prior_sigma_theta_deg > 0.0;
  auto run = [&](const FitnessEvaluator& eval, const std::vector<Correction>& initial,
                 int iterations) {
    if (!use_prior) return es_.search(eval, centre, initial, rng_, iterations);
    EsResult r =
        es_.search_with([&](const Pose2& p) { return eval.fitness(p) * prior(p, hypotheses); },
                        centre, initial, rng_, iterations);
    r.value = eval.evaluate(r.pose);
    return r;
  };
  const FitnessEvaluator fine(map_, points, fitness_options(0));
  if (config_.coarse_level <= 0) {
    return run(fine,
               make_initial_population(config_.es.mu, sigma_scale * config_.init_sigma_xy,
                                       sigma_scale * deg_to_rad(config_.init_sigma_theta_deg), rng_,
                                       extra),
               config_.es.iterations);
  }
  const FitnessEvaluator coarse(map_, points, fitness_options(config_.coarse_level));
  const int coarse_iterations = std::min(config_.coarse_iterations, config_.es.iterations);
  const EsResult rc =
      run(coarse,
          make_initial_population(config_.es.mu, sigma_scale * config_.coarse_sigma_xy,
                                  sigma_scale * deg_to_rad(config_.coarse_sigma_theta_deg), rng_,
                                  extra),
          coarse_iterations);
  EsResult r = run(fine, rc.population, config_.es.iterations - coarse_iterations);
  return r;
}

EsResult Slam::polish(const ScanPoints& points, const Pose2& start,
                      const std::vector<Pose2>& hypotheses) const {
  const FitnessEvaluator fine(map_, points, fitness_options(0));
  const bool use_prior = config_.prior_sigma_xy > 0.0 && config_.prior_sigma_theta_deg > 0.0;
  EsResult r = refine_pose_with(
      [&](const Pose2& p) { return fine.fitness(p) * (use_prior ? prior(p, hypotheses) : 1.0f); },
      start, 0.02, deg_to_rad(0.5), 0.001);
  r.value = fine.evaluate(r.pose);
  return r;
}

float Slam::median_agreement() const {
  if (recent_agreement_.empty()) return 0.0f;
  std::vector<float> v = recent_agreement_;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
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
    const auto t_search = Clock::now();
    EsResult r = search(points, step.predicted, alternatives);
    const float median = median_agreement();
    constexpr std::size_t kWarmup = 10;  // inserted scans before the median is trusted
    const bool trusted = recent_agreement_.size() >= kWarmup;
    if (trusted && config_.retry_ratio > 0.0 &&
        r.value.agreement() < config_.retry_ratio * median) {
      // A weak match: search again from a wide spread around every hypothesis.
      step.retried = true;
      const double scale_xy =
          config_.retry_sigma_xy / std::max(1e-9, config_.coarse_level > 0 ? config_.coarse_sigma_xy
                                                                           : config_.init_sigma_xy);
      EsResult wide = search(points, step.predicted, alternatives, scale_xy);
      if (wide.value.fitness > r.value.fitness) r = std::move(wide);
    }
    if (config_.refine) {
      std::vector<Pose2> hypotheses{step.predicted};
      if (config_.motion_hypotheses && !config_.prior_centre_only) {
        hypotheses.insert(hypotheses.end(), alternatives.begin(), alternatives.end());
      }
      r = polish(points, r.pose, hypotheses);
    }
    step.pose = r.pose;
    step.fitness = r.value;
    step.search_ms = ms_since(t_search);
    if (trusted && config_.gate_ratio > 0.0 && r.value.agreement() < config_.gate_ratio * median) {
      insert = false;
    }
    if (insert && last_inserted_ &&
        (config_.insert_min_travel > 0.0 || config_.insert_min_turn_deg > 0.0)) {
      const Pose2 d = step.pose.relative_to(*last_inserted_);
      insert = std::hypot(d.x, d.y) >= config_.insert_min_travel ||
               std::abs(d.theta) >= deg_to_rad(config_.insert_min_turn_deg);
    }
  }
  if (!trajectory_.empty()) {
    const Pose2& prev = trajectory_.back().pose;
    path_length_ += std::hypot(step.pose.x - prev.x, step.pose.y - prev.y);
  }
  if (insert) {
    step.inserted = true;
    const auto t_update = Clock::now();
    step.update = update_map(map_, points, step.pose, config_.update);
    step.update_ms = ms_since(t_update);
    last_inserted_ = step.pose;
    if (!trajectory_.empty()) {
      constexpr std::size_t kWindow = 50;
      if (recent_agreement_.size() < kWindow) {
        recent_agreement_.push_back(step.fitness.agreement());
      } else {
        recent_agreement_[agreement_next_] = step.fitness.agreement();
        agreement_next_ = (agreement_next_ + 1) % kWindow;
      }
    }
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
  const auto match =
      find_loop_closure(keys_, graph_.nodes(), points, pose, path_length_, config_.loop,
                        config_.map, config_.update, fitness_options(0));
  if (!match) return false;
  if (std::getenv("ESFLEET_DEBUG_LOOPS")) {
    const Pose2 d = match->pose.relative_to(pose);
    std::fprintf(stderr,
                 "loop key %zu anchor %zu: corr (%.3f %.3f %.2f deg) agree %.3f known %d/%d amb "
                 "%.3f sub %zu\n",
                 k, match->anchor, d.x, d.y, rad_to_deg(d.theta), match->value.agreement(),
                 match->value.n_known, match->value.n_points, match->ambiguity,
                 match->submap_scans);
  }
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
  apply_graph();
  return true;
}

void Slam::apply_graph() {
  constexpr double kMoveXy = 0.005;  // metres
  const double kMoveTheta = deg_to_rad(0.05);
  bool changed = false;
  for (std::size_t k = 0; k < keys_.size(); ++k) {
    KeyScan& key = keys_[k];
    const Pose2& now = graph_.node(k);
    if (std::hypot(now.x - key.mapped_pose.x, now.y - key.mapped_pose.y) < kMoveXy &&
        std::abs(normalize_angle(now.theta - key.mapped_pose.theta)) < kMoveTheta) {
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
