#include "esfleet/core/slam.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>

namespace esfleet {

void SlamConfig::validate() const {
  map.validate();
  update.validate();
  tracking.validate();
  auto check = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(what);
  };
  check(insert_min_travel >= 0.0 && insert_min_turn_deg >= 0.0,
        "slam.insert_min_travel and insert_min_turn must be >= 0");
  check(key_sigma_xy > 0.0 && key_sigma_theta_deg > 0.0,
        "slam.key_sigma_xy and key_sigma_theta must be > 0");
  check(short_view_range >= 0.0 && std::isfinite(short_view_range),
        "slam.short_view_range must be >= 0 (0 = off)");
  check(short_view_motion_hold >= 0.0 && short_view_motion_hold < 1.0,
        "slam.short_view_motion_hold must be in [0, 1)");
  if (loop.enabled) loop.validate();
  if (recovery.enabled) recovery.validate();
  contribution.validate();
}

SlamConfig SlamConfig::paper() {
  SlamConfig c;
  c.tracking.prediction = MotionPrediction::kPreviousPose;
  c.tracking.use_odometry = false;
  c.tracking.use_penalty = true;
  c.tracking.init_sigma_xy = 0.05;
  c.tracking.init_sigma_theta_deg = 2.0;
  c.tracking.motion_hypotheses = false;
  c.tracking.turn_hypotheses = false;
  c.tracking.interpolation = Interpolation::kNone;
  c.tracking.refine = false;
  c.tracking.search_point_spacing = 0.0;
  c.update.free_margin = 0.0;
  c.update.beam_fill_deg = 0.0;
  c.tracking.prior_sigma_xy = 0.0;
  c.tracking.prior_sigma_theta_deg = 0.0;
  c.insert_min_travel = 0.0;
  c.insert_min_turn_deg = 0.0;
  c.loop.enabled = false;
  c.recovery.enabled = false;
  c.short_view_motion_hold = 0.0;
  return c;
}

Slam::Slam(SlamConfig config)
    : config_(config), map_(config.map), es_(config.tracking.es), rng_(config.seed) {
  config_.validate();
  short_view_tracking_ = config_.tracking;
  short_view_tracking_.motion_hold =
      std::max(config_.tracking.motion_hold, config_.short_view_motion_hold);
}

namespace {
using Clock = std::chrono::steady_clock;
/// At most this many loop-closure searches are speculative at a time; at the limit the mapping
/// thread waits for the oldest. Run as fast as it can (offline, benchmarks), the mapping thread
/// outpaces the one worker: with 3, CSAIL's p95 per scan was that wait, 3-4x the median.
constexpr std::size_t kMaxSpeculations = 6;
/// The recovery window scales with the largest of this many last inter-scan motions.
constexpr std::size_t kScaleSteps = 5;
/// Calls f(d) for each of the last kScaleSteps inter-scan motions of `trajectory` (fewer at
/// the start), d being scan i's pose in scan i - 1's frame.
template <class F>
void for_recent_steps(const std::vector<TimedPose>& trajectory, const F& f) {
  const std::size_t n = trajectory.size();
  for (std::size_t i = n > kScaleSteps ? n - kScaleSteps : 1; i < n; ++i) {
    f(trajectory[i].pose.relative_to(trajectory[i - 1].pose));
  }
}
/// Runs work(t, threads) for t = 0 .. threads - 1, t = 0 on the calling thread, the rest on
/// threads of their own; returns when all are done. Each work takes the indices t, t + threads,
/// ... of a job list and writes its results by index, so they do not depend on `threads`.
template <class Work>
void run_strided(unsigned threads, const Work& work) {
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work, t, std::size_t{threads});
  work(std::size_t{0}, std::size_t{threads});
  for (std::thread& t : pool) t.join();
}
double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}
/// The graph edge a loop-closure match of key scan `k` stands for (loop edge weights, Huber).
PoseGraphEdge loop_edge(const LoopClosureConfig& lc, const LoopMatch& match, std::size_t k) {
  PoseGraphEdge e;
  e.from = match.anchor;
  e.to = k;
  e.measurement = match.relative;
  e.info_xy = 1.0 / (lc.sigma_xy * lc.sigma_xy);
  e.info_theta = 1.0 / std::pow(deg_to_rad(lc.sigma_theta_deg), 2);
  e.huber = lc.huber;
  return e;
}
}  // namespace

SlamStep Slam::process(const LaserScan& scan) {
  // Apply the speculative searches that are done (oldest first), and make room before a key
  // scan that may start another one.
  bool closed = false;
  const auto ready = [this] {
    return speculations_.front().search.match.wait_for(std::chrono::seconds(0)) ==
           std::future_status::ready;
  };
  while (!speculations_.empty() && (speculations_.size() >= kMaxSpeculations || ready())) {
    closed = settle_one() || closed;
  }
  SlamStep step = process_scan(scan);
  // The scan goes to every speculation started before it.
  for (Speculation& spec : speculations_) {
    if (spec.trajectory_size < trajectory_.size()) spec.scans.push_back(scan);
  }
  step.loop_closed = step.loop_closed || closed;
  return step;
}

bool Slam::settle() {
  bool closed = false;
  while (!speculations_.empty()) closed = settle_one() || closed;
  return closed;
}

bool Slam::settle_one() {
  Speculation spec = std::move(speculations_.front());
  speculations_.pop_front();
  const std::optional<LoopMatch> match = spec.search.match.get();
  if (!match) return false;
  // Judged on the graph as it was at the key scan, as on the mapping thread.
  PoseGraph graph = graph_.prefix(spec.graph_nodes, spec.graph_edges);
  if (!accept_loop(*match, spec.search.key, graph)) {
    ++loop_rejected_;
    return false;
  }
  // The later speculations started from the state this closure changes: dropped (their
  // searches run again, if due, as the scans are processed again).
  for (Speculation& later : speculations_) later.search.match.wait();
  speculations_.clear();
  // Back to right after the key scan: the later key scans out of the map (their counters
  // removed exactly), the later poses, key scans and draws forgotten.
  const std::size_t k = spec.search.key;
  for (std::size_t i = keys_.size(); i-- > k + 1;) {
    update_map(map_, *keys_[i].points, keys_[i].mapped_pose, config_.update, /*remove=*/true,
               false);
  }
  map_.commit_update();
  keys_.resize(k + 1);
  recompute_laser_reach();
  last_own_key_ = k;  // no contribution is added while a search is speculative
  trajectory_.resize(spec.trajectory_size);
  anchors_.resize(spec.trajectory_size);
  rng_.set_state(spec.rng);
  last_odometry_ = spec.last_odometry;
  last_inserted_ = spec.last_inserted;
  path_length_ = spec.path_length;
  last_jumped_ = spec.last_jumped;
  graph_ = std::move(graph);
  ++loop_closures_;
  last_loop_ = LoopEvent{k, match->anchor, match->pose.relative_to(spec.search.estimate),
                         match->value.agreement(), match->ambiguity};
  apply_graph();
  // The scans since, again, each as the mapping thread would have processed it.
  replaying_ = true;
  for (const LaserScan& s : spec.scans) process_scan(s);
  replaying_ = false;
  return true;
}

bool Slam::accept_loop(const LoopMatch& match, std::size_t k, PoseGraph& graph) const {
  const double cost_before = graph.cost();
  graph.add_edge(loop_edge(config_.loop, match, k));
  graph.optimize(10);
  // Accept only if the graph can take the closure without straining: the whole graph's cost
  // (the new edge included) may grow by at most max_chi2.
  return graph.cost() - cost_before <= config_.loop.max_chi2;
}

SlamStep Slam::process_scan(const LaserScan& scan) {
  const ScanPoints points = prepare_scan(scan, config_.tracking);
  SlamStep step;
  bool insert = true;
  if (!trajectory_.empty()) {
    MotionState motion;
    motion.last = trajectory_.back();
    if (trajectory_.size() >= 2) motion.previous = trajectory_[trajectory_.size() - 2];
    if (last_jumped_ && trajectory_.size() >= 3) {
      // The last pose was a recovery jump, taken as a correction of the estimate, not a
      // motion: the prediction continues the step before it (as the trajectory has it now,
      // after any loop closure since). If it was the robot's own motion, the recovery search
      // finds it through the jump (RecoveryConfig::through_jump).
      const TimedPose& a = trajectory_[trajectory_.size() - 3];
      const TimedPose& b = trajectory_[trajectory_.size() - 2];
      motion.previous = TimedPose{motion.last.stamp - (b.stamp - a.stamp),
                                  motion.last.pose.compose(a.pose.relative_to(b.pose))};
      motion.before_jump = b;
    }
    motion.odometry = last_odometry_;
    const bool short_view = short_view_hold() && scan.odometry && last_odometry_;
    const auto t_search = Clock::now();
    const TrackResult tracked = track_scan(short_view ? short_view_tracking_ : config_.tracking,
                                           es_, rng_, map_, points, scan, motion);
    step.predicted = tracked.predicted;
    step.pose = tracked.result.pose;
    step.fitness = tracked.result.value;
    if (config_.recovery.enabled) recover(scan, points, motion, tracked.predicted, step);
    step.search_ms = ms_since(t_search);
    // A recovered pose farther from the prediction than the motion prior's width is a jump.
    last_jumped_ = step.recovered &&
                   std::hypot(step.pose.x - step.predicted.x, step.pose.y - step.predicted.y) >
                       config_.tracking.prior_sigma_xy;
    if (last_inserted_ && (config_.insert_min_travel > 0.0 || config_.insert_min_turn_deg > 0.0)) {
      const Pose2 d = step.pose.relative_to(*last_inserted_);
      insert = std::hypot(d.x, d.y) >= config_.insert_min_travel ||
               std::abs(d.theta) >= deg_to_rad(config_.insert_min_turn_deg);
    }
    const RecoveryConfig& rc = config_.recovery;
    if (insert && rc.enabled && rc.insert_min_agreement > 0.0 &&
        step.fitness.known_share() >= rc.min_known &&
        step.fitness.agreement() < rc.insert_min_agreement) {
      insert = false;
      step.withheld = true;
    }
    if (insert && beyond_any_map(step.pose.x / map_.cell_size(), step.pose.y / map_.cell_size())) {
      insert = false;  // no map reaches it (update_map would write nothing): no key scan
      step.withheld = true;
    }
    const Pose2& prev = trajectory_.back().pose;
    path_length_ += std::hypot(step.pose.x - prev.x, step.pose.y - prev.y);
  }
  // Matched with the scan's own beams; written (and kept as a key scan) filled, if at all
  // and only while the scans are far apart.
  const MapPoints written =
      insert && scans_far_apart(step.pose)
          ? map_points(scan, config_.tracking.min_range, config_.tracking.max_range, config_.update)
          : MapPoints{};
  if (insert) {
    step.inserted = true;
    const auto t_update = Clock::now();
    step.update = update_map(map_, written.or_own(points), step.pose, config_.update);
    step.update_ms = ms_since(t_update);
    last_inserted_ = step.pose;
  }
  if (scan.odometry) last_odometry_ = scan.odometry;
  trajectory_.push_back({scan.stamp, step.pose});
  if (config_.loop.enabled) {
    if (insert) {
      anchors_.emplace_back(keys_.size(), Pose2{});
      const auto t_loop = Clock::now();
      step.loop_closed = add_key_scan(written.or_own(points), step.pose, scan.stamp);
      step.loop_ms = ms_since(t_loop);
      if (step.loop_closed) step.pose = trajectory_.back().pose;
    } else {
      const std::size_t k = last_own_key_;
      anchors_.emplace_back(k, step.pose.relative_to(graph_.node(k)));
    }
  }
  return step;
}

void Slam::recover(const LaserScan& scan, const ScanPoints& points, const MotionState& motion,
                   const Pose2& predicted, SlamStep& step) {
  const RecoveryConfig& rc = config_.recovery;
  const bool weak = weak_match(rc, step.fitness);
  // With odometry the motion is measured, not guessed: only a weak match triggers.
  const bool measured = config_.tracking.use_odometry && scan.odometry && last_odometry_;
  const Pose2 motion_step = predicted.relative_to(motion.last.pose);
  const double motion_length = std::hypot(motion_step.x, motion_step.y);
  // How far the robot could have driven since the last scan, whatever it did before.
  const double dt = scan.stamp - trajectory_.back().stamp;
  const double reach = !measured && rc.max_speed > 0.0 && dt > 0.0 ? rc.max_speed * dt : 0.0;
  const double travel = std::max(motion_length, reach);
  const bool wide =
      !measured && ((rc.wide_motion_xy > 0.0 && travel >= rc.wide_motion_xy) ||
                    (rc.wide_motion_theta_deg > 0.0 &&
                     std::abs(motion_step.theta) >= deg_to_rad(rc.wide_motion_theta_deg)));
  if (!weak && !wide) return;
  // A large motion the tracking already matched well (an in-place turn in a mapped room).
  if (!weak && rc.settled_agreement > 0.0 && step.fitness.agreement() >= rc.settled_agreement &&
      step.fitness.known_share() >= rc.settled_known) {
    return;
  }
  // The window scales with the largest recent motion (1 m or 45 degrees per scan = all of it,
  // at least window_min_scale): a robot creeping 10 cm per scan cannot be 1.5 m off, unless
  // the time since the last scan let it drive further. No motion seen yet (the second scan):
  // all of it.
  const std::size_t n = trajectory_.size();
  double scale = n < 2 ? 1.0 : std::max(rc.window_min_scale, reach / rc.window_scale_xy);
  for_recent_steps(trajectory_, [&](const Pose2& d) {
    scale = std::max(scale, std::hypot(d.x, d.y) / rc.window_scale_xy +
                                std::abs(d.theta) / deg_to_rad(rc.window_scale_theta_deg));
  });
  scale = std::min(scale, 1.0);
  // A weak match while the robot moves little per scan is clutter or a featureless stretch,
  // which the tracking's motion prior handles better than a jump.
  if (!wide && scale < rc.weak_min_scale) return;
  step.recovery_tried = true;
  RecoveryConfig scaled = rc;
  scaled.window_xy *= scale;
  scaled.window_theta_deg *= scale;
  // Without odometry, centred on the predicted position with the previous heading: a turn is
  // what a prediction gets most wrong. With it, on the odometry's pose, no farther than
  // odometry can be off over the step.
  Pose2 centre{predicted.x, predicted.y, motion.last.pose.theta};
  if (measured && rc.odometry_window_xy > 0.0) {
    centre = predicted;
    scaled.window_xy =
        std::min(scaled.window_xy, rc.odometry_window_xy + rc.odometry_window_frac * motion_length);
    scaled.window_theta_deg =
        std::min(scaled.window_theta_deg,
                 rc.odometry_window_theta_deg +
                     rc.odometry_window_frac * rad_to_deg(std::abs(motion_step.theta)));
  }
  // Its own draws, from the seed and the scan's index: the tracking's stream stays the same
  // whether or not the search ran, and a resumed run draws the same.
  Rng rng(config_.seed * 0x9E3779B97F4A7C15ULL + trajectory_.size());
  RecoveryResult r = recover_pose(scaled, config_.tracking, es_, rng, map_, points, centre);
  float recovered = consistency(map_, points, r.result.pose, rc.tolerance).score();
  if (!measured && rc.through_jump && motion.before_jump) {
    // The last pose was a jump and the prediction took it as a correction; if it was the
    // robot's own motion, constant velocity through it is where the robot is.
    const Pose2 through = constant_velocity(*motion.before_jump, motion.last, scan.stamp);
    if (std::abs(through.x - centre.x) > scaled.window_xy ||
        std::abs(through.y - centre.y) > scaled.window_xy) {
      RecoveryResult other = recover_pose(scaled, config_.tracking, es_, rng, map_, points,
                                          Pose2{through.x, through.y, centre.theta});
      const float c = consistency(map_, points, other.result.pose, rc.tolerance).score();
      if (c > recovered) {
        r = std::move(other);
        recovered = c;
      }
    }
  }
  // The farther the jump from the tracked pose (relative to the window), the clearer its gain
  // in consistency must be.
  const float gain = recovered - consistency(map_, points, step.pose, rc.tolerance).score();
  const Pose2 jump = r.result.pose.relative_to(step.pose);
  const double jump_xy = std::hypot(jump.x, jump.y);
  const double d =
      jump_xy / scaled.window_xy + std::abs(jump.theta) / deg_to_rad(scaled.window_theta_deg);
  double moved = motion_length;
  if (!measured && rc.fair_recent_pace) {
    for_recent_steps(trajectory_,
                     [&moved](const Pose2& s) { moved = std::max(moved, std::hypot(s.x, s.y)); });
  }
  const bool as_weak = judged_as_weak(rc, weak, jump_xy, moved);
  if (overlaps_enough(rc, r.result.value, step.fitness) && gain >= gain_needed(rc, as_weak, d)) {
    step.recovered = true;
    step.pose = r.result.pose;
    step.fitness = r.result.value;
  }
}

void Slam::recompute_laser_reach() {
  laser_reach_ = 0.0f;
  for (const KeyScan& key : keys_) {
    if (key.contributor != 0) continue;
    for (const float r : key.points->range) laser_reach_ = std::max(laser_reach_, r);
  }
}

bool Slam::scans_far_apart(const Pose2& pose) const {
  const MapUpdateConfig& u = config_.update;
  if (trajectory_.empty() || (u.beam_fill_min_step <= 0.0 && u.beam_fill_min_turn_deg <= 0.0)) {
    return true;
  }
  const auto far = [&u](const Pose2& d) {
    return (u.beam_fill_min_step > 0.0 && std::hypot(d.x, d.y) >= u.beam_fill_min_step) ||
           (u.beam_fill_min_turn_deg > 0.0 &&
            std::abs(d.theta) >= deg_to_rad(u.beam_fill_min_turn_deg));
  };
  bool any = far(pose.relative_to(trajectory_.back().pose));
  for_recent_steps(trajectory_, [&](const Pose2& d) { any = any || far(d); });
  return any;
}

bool Slam::add_key_scan(const ScanPoints& points, const Pose2& pose, double stamp) {
  KeyScan key;
  key.stamp = stamp;
  key.points = std::make_shared<const ScanPoints>(points);
  key.mapped_pose = pose;
  key.path_length = path_length_;
  const std::size_t k = graph_.add_node(pose);
  keys_.push_back(std::move(key));
  for (const float r : points.range) laser_reach_ = std::max(laser_reach_, r);
  if (k > 0) {
    graph_.add_edge(key_edge(last_own_key_, k, pose.relative_to(graph_.node(last_own_key_))));
  }
  last_own_key_ = k;
  bool closed = false;
  if (pending_loop_ &&
      k >= pending_loop_->key + static_cast<std::size_t>(config_.loop.defer_keys)) {
    closed = finish_loop_search();
  }
  if (k == 0 || k % static_cast<std::size_t>(config_.loop.every) != 0) return closed;
  // After an accepted closure the graph is consistent here: wait before the next attempt.
  if (last_loop_ && k - last_loop_->key < static_cast<std::size_t>(config_.loop.cooldown)) {
    return closed;
  }
  // No old scans near enough: nothing to search (no worker, no state kept).
  if (!start_loop_search(k)) return closed;
  if (config_.loop.defer_keys > 0) return closed;
  if (config_.loop.speculate && !replaying_) {
    Speculation spec{std::move(*pending_loop_),
                     rng_.state(),
                     trajectory_.size(),
                     last_odometry_,
                     last_inserted_,
                     path_length_,
                     last_jumped_,
                     graph_.node_count(),
                     graph_.edges().size(),
                     {}};
    pending_loop_.reset();
    speculations_.push_back(std::move(spec));
    return closed;
  }
  return finish_loop_search() || closed;
}

bool Slam::start_loop_search(std::size_t k) {
  const LoopClosureConfig& lc = config_.loop;
  const Pose2 estimate = graph_.node(k);
  const double path_length = keys_[k].path_length;
  // The old scans find_loop_closure would use (same filter, nearest first, at most
  // max_submap_scans), handed over in index order so that it orders and anchors them as it
  // would among all key scans.
  std::vector<std::pair<double, std::size_t>> near;
  bool trigger = false;
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (path_length - keys_[i].path_length < lc.min_travel) continue;
    const Pose2& p = graph_.node(i);
    const double d = std::hypot(p.x - estimate.x, p.y - estimate.y);
    if (d <= lc.search_radius) trigger = true;
    if (d <= lc.submap_radius) near.emplace_back(d, i);
  }
  std::vector<std::size_t> ids;
  LoopClosureConfig search_config = lc;
  if (trigger && near.size() >= 3) {
    std::sort(near.begin(), near.end());
    if (near.size() > static_cast<std::size_t>(lc.max_submap_scans)) {
      near.resize(static_cast<std::size_t>(lc.max_submap_scans));
    }
    for (const auto& [d, i] : near) ids.push_back(i);
    std::sort(ids.begin(), ids.end());
    // The window grows with the drift plausible since the nearest old scan.
    search_config.window_xy =
        loop_search_window_xy(lc, path_length - keys_[near.front().second].path_length);
  }
  if (ids.empty()) return false;
  std::vector<KeyScan> old_keys;
  std::vector<Pose2> old_poses;
  old_keys.reserve(ids.size());
  for (const std::size_t i : ids) {
    old_keys.push_back(keys_[i]);
    old_poses.push_back(graph_.node(i));
  }
  auto search = [ids = std::move(ids), old_keys = std::move(old_keys),
                 old_poses = std::move(old_poses), points = *keys_[k].points, estimate, path_length,
                 lc = search_config, map = config_.map, update = config_.update, shared = submap_,
                 fitness = slam_fitness_options(
                     config_.tracking, config_.tracking.interpolation !=
                                           Interpolation::kNone)]() -> std::optional<LoopMatch> {
    const std::lock_guard lock(shared->mutex);
    auto match = find_loop_closure(old_keys, old_poses, points, estimate, path_length, lc, map,
                                   update, fitness, &shared->cache);
    shared->cache.trim();
    if (match) match->anchor = ids[match->anchor];
    return match;
  };
  const bool speculative = lc.defer_keys == 0 && lc.speculate && !replaying_;
  const auto policy = lc.defer_keys > 0 || speculative ? std::launch::async : std::launch::deferred;
  // Speculative searches run one after another: never more than one worker thread.
  std::shared_future<std::optional<LoopMatch>> previous;
  if (speculative && !speculations_.empty()) previous = speculations_.back().search.match;
  pending_loop_ =
      PendingLoop{k, estimate, std::async(policy, [search = std::move(search), previous]() mutable {
                                 if (previous.valid()) previous.wait();
                                 return search();
                               }).share()};
  return true;
}

bool Slam::finish_loop_search() {
  PendingLoop pending = std::move(*pending_loop_);
  pending_loop_.reset();
  const std::optional<LoopMatch> match = pending.match.get();
  if (!match) return false;
  const std::size_t k = pending.key;
  PoseGraph graph = graph_;
  if (!accept_loop(*match, k, graph)) {
    // The graph cannot agree with this closure: drop it.
    ++loop_rejected_;
    return false;
  }
  graph_ = std::move(graph);
  ++loop_closures_;
  last_loop_ = LoopEvent{k, match->anchor, match->pose.relative_to(pending.estimate),
                         match->value.agreement(), match->ambiguity};
  apply_graph();
  return true;
}

SlamFinish Slam::finish(unsigned threads) {
  const auto t0 = Clock::now();
  SlamFinish out;
  if (!config_.loop.enabled) return out;
  bool changed = settle();
  changed = (pending_loop_ && finish_loop_search()) || changed;
  {
    // No online search follows: the last submap's memory goes before the final pass's.
    const std::lock_guard lock(submap_->mutex);
    submap_->cache.clear();
  }
  const LoopClosureConfig& lc = config_.loop;
  if (lc.final_pass && keys_.size() > 1) {
    LoopClosureConfig fc = lc;
    fc.window_xy = lc.final_window_xy;
    fc.window_theta_deg = lc.final_window_theta_deg;
    fc.search_radius = lc.final_submap_radius;
    fc.submap_radius = lc.final_submap_radius;
    fc.max_submap_scans = lc.final_max_submap_scans;
    fc.rival_distance = lc.final_rival_distance;
    fc.max_ambiguity = lc.final_max_ambiguity;
    fc.degenerate_ratio = lc.final_degenerate_ratio;
    const FitnessOptions fitness = slam_fitness_options(
        config_.tracking, config_.tracking.interpolation != Interpolation::kNone);
    threads = std::max(threads, 1u);
    const auto every = static_cast<std::size_t>(std::max(lc.final_every, 1));
    const std::size_t n = keys_.size();
    // The graph as the online SLAM left it (the chain sharpened by ICP); each round replaces
    // the previous round's edges.
    std::vector<PoseGraphEdge> online_edges = graph_.edges();
    add_icp_edges(online_edges, threads, out);
    for (int round = 0; round < std::max(lc.final_rounds, 1); ++round) {
      const std::vector<Pose2> poses = graph_.nodes();
      std::vector<std::optional<LoopMatch>> matches(n);
      // Independent searches, results by index: the same for any number of threads.
      // find_loop_closure takes only scans at least min_travel back along the path: each
      // revisit is found from its later end.
      // Each thread builds a search's submap from its previous one (the same result).
      auto work = [&](std::size_t first, std::size_t step) {
        SubmapCache cache;
        for (std::size_t k = first * every; k < n; k += step * every) {
          matches[k] =
              find_loop_closure(keys_, poses, *keys_[k].points, poses[k], keys_[k].path_length, fc,
                                config_.map, config_.update, fitness, &cache);
        }
      };
      run_strided(threads, work);
      PoseGraph g;
      g.set_nodes(poses);
      for (const PoseGraphEdge& e : online_edges) g.add_edge(e);
      std::size_t matched = 0;
      for (std::size_t k = 0; k < n; ++k) {
        if (!matches[k]) continue;
        ++matched;
        g.add_edge(loop_edge(lc, *matches[k], k));
      }
      out.tried = (n + every - 1) / every;
      out.matched = matched;
      out.kept = 0;
      if (matched == 0) {
        if (round == 0 && out.icp_aligned > 0) {
          // No match from other times, but the chain is sharper: optimise with it alone.
          PoseGraph chain;
          chain.set_nodes(poses);
          for (const PoseGraphEdge& e : online_edges) chain.add_edge(e);
          chain.optimize(20);
          graph_ = std::move(chain);
          changed = true;
        }
        break;
      }
      g.optimize(20);
      // Drop the matches the optimised graph disagrees with, and optimise again without them.
      PoseGraph kept;
      kept.set_nodes(poses);
      for (std::size_t i = 0; i < g.edges().size(); ++i) {
        const PoseGraphEdge& e = g.edges()[i];
        if (i < online_edges.size() || g.edge_chi2(e) <= lc.final_max_edge_chi2) {
          kept.add_edge(e);
          out.kept += i < online_edges.size() ? 0 : 1;
        }
      }
      g = PoseGraph{};  // its copy of every edge goes before the optimisation (peak memory)
      kept.optimize(20);
      graph_ = std::move(kept);
      changed = true;
    }
  }
  if (changed) apply_graph();
  out.ms = ms_since(t0);
  return out;
}

PoseGraphEdge Slam::key_edge(std::size_t from, std::size_t to, const Pose2& measurement) const {
  PoseGraphEdge e;
  e.from = from;
  e.to = to;
  e.measurement = measurement;
  e.info_xy = 1.0 / (config_.key_sigma_xy * config_.key_sigma_xy);
  e.info_theta = 1.0 / std::pow(deg_to_rad(config_.key_sigma_theta_deg), 2);
  return e;
}

void Slam::add_icp_edges(std::vector<PoseGraphEdge>& edges, unsigned threads,
                         SlamFinish& out) const {
  const auto neighbours = static_cast<std::size_t>(std::max(config_.loop.final_icp_neighbours, 0));
  if (neighbours == 0) return;
  constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  // The leader's own key scans in the order it inserted them (contributed scans have chains of
  // their own), and the chain edge into each: from the own key scan before it.
  std::vector<std::size_t> own;
  for (std::size_t k = 0; k < keys_.size(); ++k) {
    if (keys_[k].contributor == 0) own.push_back(k);
  }
  std::vector<std::size_t> chain_edge(keys_.size(), kNone);
  for (std::size_t i = 0; i < edges.size(); ++i) {
    const PoseGraphEdge& e = edges[i];
    if (e.huber == 0.0 && keys_[e.from].contributor == 0 && keys_[e.to].contributor == 0) {
      chain_edge[e.to] = i;
    }
  }
  struct Pair {
    std::size_t from, to, edge;  // edge: the chain edge it sharpens, or kNone (a new edge)
    Pose2 start;
    std::optional<IcpResult> aligned;
  };
  std::vector<Pair> pairs;
  for (std::size_t i = 1; i < own.size(); ++i) {
    const std::size_t b = own[i];
    const std::size_t e = chain_edge[b];
    for (std::size_t d = 1; d <= neighbours && d <= i; ++d) {
      const std::size_t a = own[i - d];
      // Scans farther apart see the place from too far another viewpoint: fr079 kept every 8th
      // scan (0.8 m apart) scored worse with them aligned than with the tracked motion.
      const Pose2 rel = graph_.node(b).relative_to(graph_.node(a));
      if (std::hypot(rel.x, rel.y) > config_.loop.final_icp_max_distance) continue;
      if (d == 1 && e != kNone && edges[e].from == a) {
        pairs.push_back({a, b, e, edges[e].measurement, std::nullopt});
      } else {
        pairs.push_back({a, b, kNone, rel, std::nullopt});
      }
    }
  }
  // Independent alignments, results by index: the same for any number of threads.
  auto work = [&](std::size_t first, std::size_t step) {
    for (std::size_t i = first; i < pairs.size(); i += step) {
      Pair& p = pairs[i];
      const auto r =
          align_scans(*keys_[p.from].points, *keys_[p.to].points, p.start, config_.loop.icp);
      p.aligned = r;
    }
  };
  run_strided(std::max(threads, 1u), work);
  out.icp_tried = pairs.size();
  for (const Pair& p : pairs) {
    if (!p.aligned) continue;
    ++out.icp_aligned;
    out.icp_held += p.aligned->held_along ? 1 : 0;
    if (p.edge != kNone) {
      edges[p.edge].measurement = p.aligned->relative;
    } else {
      edges.push_back(key_edge(p.from, p.to, p.aligned->relative));
    }
  }
}

void Slam::apply_graph() {
  {
    // The optimised graph moves the scans the last submap was built from, so the next search
    // builds from scratch anyway: free it now, before the re-writes below (the run's peak
    // memory). If a search holds it, it stays (the result does not depend on it).
    const std::unique_lock lock(submap_->mutex, std::try_to_lock);
    if (lock.owns_lock()) submap_->cache.clear();
  }
  const double move_xy = config_.loop.move_min_xy;
  const double move_theta = deg_to_rad(config_.loop.move_min_theta_deg);
  std::vector<bool> moves(keys_.size());
  std::size_t moved = 0;
  for (std::size_t k = 0; k < keys_.size(); ++k) {
    const Pose2& was = keys_[k].mapped_pose;
    const Pose2& now = graph_.node(k);
    moves[k] = !(std::hypot(now.x - was.x, now.y - was.y) < move_xy &&
                 std::abs(normalize_angle(now.theta - was.theta)) < move_theta);
    moved += moves[k] ? 1 : 0;
  }
  // The map is the sum of its key scans' counts, so writing every key scan again into a
  // cleared map gives the same counters as taking out and writing again the ones that moved:
  // one walk per key scan against two per moved one (a closure at the end of a long loop, and
  // the final pass, move most of them).
  const bool rewrite_all = 2 * moved > keys_.size();
  if (rewrite_all) map_.clear_counters();
  for (std::size_t k = 0; k < keys_.size(); ++k) {
    KeyScan& key = keys_[k];
    if (moves[k]) {
      if (!rewrite_all) {
        update_map(map_, *key.points, key.mapped_pose, config_.update, /*remove=*/true, false);
      }
      key.mapped_pose = graph_.node(k);
      update_map(map_, *key.points, key.mapped_pose, config_.update, false, false);
    } else if (rewrite_all) {
      update_map(map_, *key.points, key.mapped_pose, config_.update, false, false);
    }
  }
  if (moved > 0) map_.commit_update();
  for (std::size_t t = 0; t < trajectory_.size(); ++t) {
    const auto& [k, rel] = anchors_[t];
    trajectory_[t].pose = graph_.node(k).compose(rel);
  }
  last_inserted_ = graph_.node(last_own_key_);
}

ContributionResult Slam::contribute(const Contribution& c) {
  const ContributionConfig& cc = config_.contribution;
  ContributionResult r;
  r.refined = c.pose;
  // Judged against the map as the mapping thread has it, whatever the worker is doing.
  r.loop_closed = settle();
  const ScanPoints points = prepare_scan(c.scan, config_.tracking);
  if (points.size() < static_cast<std::size_t>(cc.min_beams) || keys_.empty()) return r;
  const FitnessOptions options = slam_fitness_options(
      config_.tracking, config_.tracking.interpolation != Interpolation::kNone);
  // 1. The scan agrees with the map where the contributor says it was.
  r.value = FitnessEvaluator(map_, points, options).evaluate(c.pose);
  if (r.value.known_share() < cc.min_known) {
    r.verdict = ContributionVerdict::kUnknownPlace;
    return r;
  }
  if (r.value.agreement() < cc.min_agreement) {
    r.verdict = ContributionVerdict::kDisagrees;
    return r;
  }
  // Where a key scan already is, one more adds little: skipped before the refine's cost. Not
  // against the contributor's own recent scans: in new space it must extend the map at the
  // key-scan spacing to keep tracking there.
  if (cc.redundant_xy > 0.0) {
    const double turn = deg_to_rad(cc.redundant_theta_deg);
    std::uint32_t own = 0;
    for (std::size_t i = 0; i < contributors_.size(); ++i) {
      if (contributors_[i] == c.robot) own = static_cast<std::uint32_t>(i + 1);
    }
    for (std::size_t i = 0; i < keys_.size(); ++i) {
      if (own != 0 && keys_[i].contributor == own &&
          c.scan.stamp - keys_[i].stamp < cc.redundant_own_after_s) {
        continue;
      }
      const Pose2& p = graph_.node(i);
      if (std::hypot(p.x - c.pose.x, p.y - c.pose.y) <= cc.redundant_xy &&
          std::abs(normalize_angle(p.theta - c.pose.theta)) <= turn) {
        r.verdict = ContributionVerdict::kRedundant;
        return r;
      }
    }
  }
  // 2. The same ES, started at the claimed pose, moves it only a little. Its own draws: the
  // SLAM's stream stays as it is, and the same contribution refines the same way.
  std::uint64_t h = 1469598103934665603ULL;
  for (const char ch : c.robot) h = (h ^ static_cast<unsigned char>(ch)) * 1099511628211ULL;
  Rng rng(config_.seed * 0x9E3779B97F4A7C15ULL ^ h ^ (static_cast<std::uint64_t>(c.seq) << 20));
  TrackingConfig tc = config_.tracking;
  tc.use_odometry = false;
  tc.prediction = MotionPrediction::kPreviousPose;
  tc.motion_hypotheses = false;
  tc.turn_hypotheses = false;
  MotionState motion;
  motion.last = {c.scan.stamp, c.pose};
  const TrackResult refined = track_scan(tc, es_, rng, map_, points, c.scan, motion);
  r.refined = refined.result.pose;
  r.value = refined.result.value;
  const Pose2 moved = r.refined.relative_to(c.pose);
  r.moved_xy = std::hypot(moved.x, moved.y);
  r.moved_theta_deg = std::abs(rad_to_deg(moved.theta));
  if (r.moved_xy > cc.max_refine_xy || r.moved_theta_deg > cc.max_refine_theta_deg) {
    r.verdict = ContributionVerdict::kRefineMoved;
    return r;
  }
  if (r.value.agreement() < cc.min_agreement) {
    r.verdict = ContributionVerdict::kDisagrees;
    return r;
  }
  // 3. No beam may pass through what the map has seen occupied many times.
  r.contradiction = occupied_contradiction(map_, points, r.refined, cc.contradiction_min_hits,
                                           cc.contradiction_margin);
  if (r.contradiction > cc.max_contradiction) {
    r.verdict = ContributionVerdict::kContradicts;
    return r;
  }
  r.verdict = ContributionVerdict::kAccepted;
  const MapPoints written =
      map_points(c.scan, config_.tracking.min_range, config_.tracking.max_range, config_.update);
  const ScanPoints& inserted = written.or_own(points);
  update_map(map_, inserted, r.refined, config_.update);
  if (!config_.loop.enabled) return r;
  // A key scan of the pose graph.
  std::size_t who = 0;
  while (who < contributors_.size() && contributors_[who] != c.robot) ++who;
  if (who == contributors_.size()) {
    contributors_.push_back(c.robot);
    chains_.emplace_back();
  }
  KeyScan key;
  key.stamp = c.scan.stamp;
  key.points = std::make_shared<const ScanPoints>(inserted);
  key.mapped_pose = r.refined;
  key.path_length = kContributedPathLength;
  key.contributor = static_cast<std::uint32_t>(who + 1);
  const std::size_t k = graph_.add_node(r.refined);
  keys_.push_back(std::move(key));
  ++contributed_keys_;
  std::optional<ContributorChain>& chain = chains_[who];
  double travel = 0.0;
  if (chain &&
      std::hypot(c.pose.x - chain->claimed.x, c.pose.y - chain->claimed.y) <= cc.chain_max_gap) {
    // Its own motion between its two scans, as it tracked it.
    PoseGraphEdge e;
    e.from = chain->key;
    e.to = k;
    e.measurement = c.pose.relative_to(chain->claimed);
    e.info_xy = 1.0 / (cc.chain_sigma_xy * cc.chain_sigma_xy);
    e.info_theta = 1.0 / std::pow(deg_to_rad(cc.chain_sigma_theta_deg), 2);
    graph_.add_edge(e);
    travel = chain->unanchored_travel + std::hypot(e.measurement.x, e.measurement.y);
  }
  // Where the refine put it, relative to the nearest key scan of another robot.
  std::optional<std::size_t> anchor;
  double best = cc.anchor_radius;
  for (std::size_t i = 0; i < k; ++i) {
    if (keys_[i].contributor == who + 1) continue;
    const Pose2& p = graph_.node(i);
    const double d = std::hypot(p.x - r.refined.x, p.y - r.refined.y);
    if (d <= best) {
      best = d;
      anchor = i;
    }
  }
  if (anchor) {
    PoseGraphEdge e;
    e.from = *anchor;
    e.to = k;
    e.measurement = r.refined.relative_to(graph_.node(*anchor));
    e.info_xy = 1.0 / (cc.anchor_sigma_xy * cc.anchor_sigma_xy);
    e.info_theta = 1.0 / std::pow(deg_to_rad(cc.anchor_sigma_theta_deg), 2);
    e.huber = config_.loop.huber;
    const bool closes = chain.has_value() && travel >= cc.loop_chain_travel;
    graph_.add_edge(e);
    travel = 0.0;
    if (closes) {
      // A loop through unmapped space closed by this robot: the whole graph takes it.
      graph_.optimize(10);
      apply_graph();
      r.loop_closed = true;
    }
  } else if (!chain || travel == 0.0) {
    // Neither chained nor anchored: tie it to the leader's last key scan, weakly, so the graph
    // stays connected (the optimiser holds only node 0 fixed).
    PoseGraphEdge e;
    e.from = last_own_key_;
    e.to = k;
    e.measurement = r.refined.relative_to(graph_.node(last_own_key_));
    e.info_xy = 1.0;
    e.info_theta = 1.0;
    graph_.add_edge(e);
  }
  chain = ContributorChain{k, c.pose, travel};
  return r;
}

SlamState Slam::state() const {
  if (!speculations_.empty()) {
    throw std::logic_error("Slam::state() while a loop-closure search is speculative: settle()");
  }
  SlamState s;
  s.rng = rng_.state();
  s.trajectory = trajectory_;
  s.last_odometry = last_odometry_;
  s.last_inserted = last_inserted_;
  s.path_length = path_length_;
  s.keys = keys_;
  s.graph_nodes = graph_.nodes();
  s.graph_edges = graph_.edges();
  s.anchors = anchors_;
  s.loop_closures = loop_closures_;
  s.loop_rejected = loop_rejected_;
  s.last_loop = last_loop_;
  if (pending_loop_) s.pending_loop_key = pending_loop_->key;
  s.contributors = contributors_;
  s.last_jumped = last_jumped_;
  return s;
}

void Slam::restore(SlamState s) {
  auto check = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("slam state: " + what);
  };
  check(s.graph_nodes.size() == s.keys.size(),
        "graph_nodes (" + std::to_string(s.graph_nodes.size()) + ") != keys (" +
            std::to_string(s.keys.size()) + ")");
  for (std::size_t i = 0; i < s.graph_edges.size(); ++i) {
    const PoseGraphEdge& e = s.graph_edges[i];
    check(e.from < s.keys.size() && e.to < s.keys.size() && e.from != e.to,
          "graph_edges[" + std::to_string(i) + "] node indices invalid");
  }
  check(s.anchors.empty() || s.anchors.size() == s.trajectory.size(),
        "anchors (" + std::to_string(s.anchors.size()) + ") != trajectory (" +
            std::to_string(s.trajectory.size()) + ")");
  for (std::size_t i = 0; i < s.anchors.size(); ++i) {
    check(s.anchors[i].first < s.keys.size(),
          "anchors[" + std::to_string(i) + "] key index out of range");
  }
  check(!config_.loop.enabled || s.trajectory.empty() || s.anchors.size() == s.trajectory.size(),
        "loop closure is on but the state has no anchors (saved with loop closure off?)");
  check(s.last_loop.has_value() == false || s.last_loop->key < s.keys.size(),
        "last_loop.key out of range");
  check(!s.pending_loop_key || *s.pending_loop_key < s.keys.size(),
        "pending_loop_key out of range");
  for (std::size_t i = 0; i < s.keys.size(); ++i) {
    check(s.keys[i].contributor <= s.contributors.size(),
          "keys[" + std::to_string(i) + "].contributor out of range");
  }
  rng_.set_state(s.rng);
  trajectory_ = std::move(s.trajectory);
  last_odometry_ = s.last_odometry;
  last_inserted_ = s.last_inserted;
  path_length_ = s.path_length;
  last_jumped_ = s.last_jumped;
  keys_ = std::move(s.keys);
  recompute_laser_reach();
  contributors_ = std::move(s.contributors);
  // The contributors' chains start afresh: their next scans are tied to the graph by anchors.
  chains_.assign(contributors_.size(), std::nullopt);
  last_own_key_ = 0;
  contributed_keys_ = 0;
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    if (keys_[i].contributor == 0) {
      last_own_key_ = i;
    } else {
      ++contributed_keys_;
    }
  }
  graph_ = PoseGraph{};
  graph_.set_nodes(std::move(s.graph_nodes));
  for (const PoseGraphEdge& e : s.graph_edges) graph_.add_edge(e);
  anchors_ = std::move(s.anchors);
  loop_closures_ = s.loop_closures;
  loop_rejected_ = s.loop_rejected;
  last_loop_ = s.last_loop;
  pending_loop_.reset();
  for (Speculation& spec : speculations_) spec.search.match.wait();
  speculations_.clear();
  replaying_ = false;
  // A state read only to look at its map (loop closure off) leaves the search undone.
  if (s.pending_loop_key && config_.loop.enabled) start_loop_search(*s.pending_loop_key);
}

}  // namespace esfleet
