#include "esfleet/core/localiser.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "esfleet/core/clock.hpp"
#include "esfleet/core/fitness.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet {

const char* to_string(LocaliserState s) {
  switch (s) {
    case LocaliserState::kWaitingForMap:
      return "waiting_for_map";
    case LocaliserState::kLocalising:
      return "localising";
    case LocaliserState::kTracking:
      return "tracking";
    case LocaliserState::kLost:
      return "lost";
  }
  return "unknown";
}

void LocaliserConfig::validate() const {
  tracking.validate();
  search.validate();
  auto check = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(what);
  };
  check(confirm_scans >= 1, "localise.confirm_scans must be >= 1");
  check(min_agreement >= 0.0 && min_agreement <= 1.0, "localise.min_agreement must be in [0, 1]");
  check(min_known >= 0.0 && min_known <= 1.0, "localise.min_known must be in [0, 1]");
  check(min_travel >= 0.0 && min_turn_deg >= 0.0, "localise.min_travel and min_turn must be >= 0");
  check(max_ambiguity > 0.0 && max_ambiguity <= 1.0, "localise.max_ambiguity must be in (0, 1]");
  check(verify_ambiguity > 0.0 && verify_ambiguity <= 1.0,
        "localise.verify_ambiguity must be in (0, 1]");
  check(max_hypotheses >= 1, "localise.max_hypotheses must be >= 1");
  check(research_every >= 1, "localise.research_every must be >= 1");
  check(research_every_max >= research_every,
        "localise.research_every_max must be >= localise.research_every");
  check(contradiction_factor >= 0.0 && std::isfinite(contradiction_factor) &&
            contradiction_margin >= 0.0 && contradiction_margin <= 1.0,
        "localise.contradiction_factor must be >= 0, contradiction_margin in [0, 1]");
  check(contradiction_min_agreement >= 0.0 && contradiction_min_agreement <= 1.0 &&
            contradiction_min_known >= 0.0 && contradiction_min_known <= 1.0,
        "localise.contradiction_min_agreement and contradiction_min_known must be in [0, 1]");
  check(contradiction_min_streak >= 1, "localise.contradiction_min_streak must be >= 1");
  check(hypothesis_iterations >= 0, "localise.hypothesis_iterations must be >= 0");
  check(prune_ratio >= 0.0 && prune_ratio < 1.0, "localise.prune_ratio must be in [0, 1)");
  check(lost_scans >= 1, "localise.lost_scans must be >= 1");
  check(motion_hold >= 0.0 && motion_hold < 1.0, "localise.motion_hold must be in [0, 1)");
  check(hint_scans >= 1, "localise.hint_scans must be >= 1");
  if (hint) {
    check(hint->radius >= 0.0 && std::isfinite(hint->radius), "hint radius must be >= 0");
    check(hint->angle_deg >= 0.0 && hint->angle_deg <= 180.0,
          "hint angle must be in [0, 180] degrees");
  }
}

namespace {

/// Poses closer than this are the same for the final check before declaring (the benchmark's
/// tolerance for a right pose is 0.3 m and 5 deg).
constexpr double kRivalXy = 0.3;
const double kRivalTheta = deg_to_rad(5.0);

/// The local check before declaring: a window of +-kLocalCheckXy (steps of kLocalCheckStep) and
/// +-kLocalCheckTurns degrees; a pose whose evidence beats the leader's by kLocalCheckMargin
/// and lies more than kLocalCheckMove away takes the hypothesis over.
constexpr double kLocalCheckXy = 0.5;
constexpr double kLocalCheckStep = 0.05;
constexpr int kLocalCheckTurns = 3;
constexpr float kLocalCheckMargin = 0.01f;
constexpr double kLocalCheckMove = 0.1;

}  // namespace

Localiser::Localiser(LocaliserConfig config)
    : config_(std::move(config)),
      es_(config_.tracking.es),
      hypothesis_es_([this] {
        EsConfig c = config_.tracking.es;
        c.iterations = config_.hypothesis_iterations;
        return c;
      }()),
      search_([this] {
        config_.validate();  // all of it first, so errors come in validate()'s order
        config_.tracking.motion_hold = config_.motion_hold;
        return GlobalSearch(config_.search, config_.tracking);
      }()),
      rng_(config_.seed) {
  research_wait_ = config_.research_every;
}

void Localiser::reset() {
  state_ = LocaliserState::kWaitingForMap;
  pool_.clear();
  scans_since_search_ = 0;
  research_wait_ = config_.research_every;
  searching_scans_ = 0;
  bad_streak_ = 0;
}

void Localiser::set_hint(const PoseHint& hint) {
  LocaliserConfig c = config_;
  c.hint = hint;
  c.validate();
  config_.hint = hint;
  reset();
}

std::vector<HypothesisView> Localiser::hypothesis_views() const {
  std::vector<HypothesisView> out;
  for (const Hypothesis& h : pool_) {
    out.push_back({h.id, h.motion.last.pose, h.score, h.good_streak, h.travel, h.value});
  }
  return out;
}

FitnessEvaluator Localiser::fine_evaluator(const GridMap& map, const ScanPoints& points) const {
  return FitnessEvaluator(map, points,
                          slam_fitness_options(config_.tracking, config_.tracking.interpolation !=
                                                                     Interpolation::kNone));
}

bool Localiser::good(const FitnessValue& v) const {
  return v.agreement() >= config_.min_agreement && v.known_share() >= config_.min_known;
}

std::vector<Pose2> Localiser::search_globally(const GridMap& map, const ScanPoints& points,
                                              bool use_hint, GlobalSearchMethod how) {
  const PoseHint* hint = use_hint && config_.hint ? &*config_.hint : nullptr;
  if (observer_ == nullptr || !observer_->wants_search_stages()) {
    return search_.run(map, points, hint, how, rng_);
  }
  SearchStages stages;
  std::vector<Pose2> candidates = search_.run(map, points, hint, how, rng_, &stages);
  observer_->on_search_stages(stages);
  return candidates;
}

void Localiser::score_scan(Hypothesis& h, const FitnessValue& v, const Pose2& before,
                           const Pose2& now) {
  h.value = v;
  ++h.scans;
  h.travel += std::hypot(now.x - before.x, now.y - before.y);
  h.turn += std::abs(normalize_angle(now.theta - before.theta));
  h.good_streak = good(v) ? h.good_streak + 1 : 0;
  h.recent.push_back(v);
  const auto window = static_cast<std::size_t>(config_.confirm_scans);
  if (h.recent.size() > window) h.recent.erase(h.recent.begin());
  float e = 0.0f, c = 0.0f, a = 0.0f, k = 0.0f;
  for (const FitnessValue& r : h.recent) {
    e += evidence(r);
    c += contradiction(r);
    a += r.agreement();
    k += static_cast<float>(r.known_share());
  }
  const auto n = static_cast<float>(h.recent.size());
  h.score = e / n;
  h.contradiction = c / n;
  h.agreement = a / n;
  h.known = k / n;
}

bool Localiser::contradiction_route(const Hypothesis& h) const {
  return config_.contradiction_factor > 0.0 && h.good_streak >= config_.contradiction_min_streak &&
         h.agreement >= static_cast<float>(config_.contradiction_min_agreement) &&
         h.known >= static_cast<float>(config_.contradiction_min_known);
}

bool Localiser::contradicted(float rival, float own) const {
  return rival >= static_cast<float>(config_.contradiction_factor) * own +
                      static_cast<float>(config_.contradiction_margin);
}

bool Localiser::clear_of(const Hypothesis& h, const Hypothesis& rival) const {
  if (rival.score <= static_cast<float>(config_.max_ambiguity) * h.score) return true;
  return contradiction_route(h) && contradicted(rival.contradiction, h.contradiction);
}

void Localiser::add_hypotheses(const std::vector<Pose2>& poses, const GridMap& map,
                               const ScanPoints& points, const LaserScan& scan) {
  const FitnessEvaluator eval = fine_evaluator(map, points);
  for (const Pose2& p : poses) {
    const bool known = std::any_of(pool_.begin(), pool_.end(), [&](const Hypothesis& h) {
      return same_place(h.motion.last.pose, p, 0.3, deg_to_rad(10.0));
    });
    if (known) continue;
    Hypothesis h;
    h.id = ++next_id_;
    h.motion.last = {scan.stamp, p};
    h.motion.odometry = scan.odometry;
    h.origin = p;
    score_scan(h, eval.evaluate(p), p, p);
    pool_.push_back(std::move(h));
  }
}

void Localiser::follow_hypotheses(const GridMap& map, const ScanPoints& points,
                                  const LaserScan& scan) {
  for (Hypothesis& h : pool_) {
    const TrackResult t =
        track_scan(config_.tracking, hypothesis_es_, rng_, map, points, scan, h.motion);
    const Pose2 before = h.motion.last.pose;
    h.motion.previous = h.motion.last;
    h.motion.last = {scan.stamp, t.result.pose};
    if (scan.odometry) h.motion.odometry = scan.odometry;
    score_scan(h, t.result.value, before, t.result.pose);
  }
  // Merge hypotheses that converged onto one pose; drop the clearly worse.
  std::stable_sort(pool_.begin(), pool_.end(),
                   [](const Hypothesis& a, const Hypothesis& b) { return a.score > b.score; });
  std::vector<Hypothesis> kept;
  for (Hypothesis& h : pool_) {
    const bool dup = std::any_of(kept.begin(), kept.end(), [&](const Hypothesis& k) {
      return same_place(k.motion.last.pose, h.motion.last.pose, 0.3, deg_to_rad(10.0));
    });
    if (dup) continue;
    if (!kept.empty() && h.scans >= 2 &&
        h.score < static_cast<float>(config_.prune_ratio) * kept.front().score) {
      continue;
    }
    kept.push_back(std::move(h));
    if (static_cast<int>(kept.size()) >= config_.max_hypotheses) break;
  }
  pool_ = std::move(kept);
}

void Localiser::search_if_due(const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                              LocaliserStep& step) {
  const bool use_hint = config_.hint && searching_scans_ <= config_.hint_scans;
  const bool any_good = std::any_of(pool_.begin(), pool_.end(),
                                    [](const Hypothesis& h) { return h.good_streak > 0; });
  if (any_good) research_wait_ = config_.research_every;
  if (pool_.empty() || (!any_good && scans_since_search_ >= research_wait_)) {
    // A search that follows scans where nothing matched well: wait longer for the next one.
    if (!pool_.empty()) research_wait_ = std::min(2 * research_wait_, config_.research_every_max);
    add_hypotheses(search_globally(map, points, use_hint, config_.search.method), map, points,
                   scan);
    scans_since_search_ = 0;
    step.global_search = true;
  } else {
    ++scans_since_search_;
  }
}

bool Localiser::ready(std::size_t i) const {
  const Hypothesis& c = pool_[i];
  const bool moved = c.travel >= config_.min_travel || c.turn >= deg_to_rad(config_.min_turn_deg);
  if (c.good_streak < config_.confirm_scans || !moved || !(c.score > 0.0f)) return false;
  for (std::size_t j = 0; j < pool_.size(); ++j) {
    if (j != i && !clear_of(c, pool_[j])) return false;
  }
  return true;
}

std::pair<std::size_t, bool> Localiser::leader() const {
  std::size_t lead = 0;
  for (std::size_t i = 1; i < pool_.size(); ++i) {
    if (pool_[i].score > pool_[lead].score) lead = i;
  }
  if (ready(lead)) return {lead, true};
  if (config_.contradiction_factor > 0.0) {
    // The contradiction route: another hypothesis may be clear of all the others.
    for (std::size_t i = 0; i < pool_.size(); ++i) {
      if (i != lead && contradiction_route(pool_[i]) && ready(i)) return {i, true};
    }
  }
  return {lead, false};
}

bool Localiser::moved_by_local_check(const FitnessEvaluator& fine, std::size_t lead,
                                     LocaliserStep& step) {
  // Is the leader the best explanation of this scan nearby? Along a corridor the fitness
  // optimum can sit a few decimetres from where the map fits the scan best (CSAIL: evidence
  // 0.98 at the tracked pose, 1.00 0.34 m further). If a pose in the window explains the
  // scan better, the hypothesis moves there and must confirm again.
  Hypothesis& lead_h = pool_[lead];
  const Pose2 c = lead_h.motion.last.pose;
  const float lead_e = evidence(fine.evaluate(c));
  const auto [best, best_e] =
      best_evidence_near(fine, c, kLocalCheckXy, kLocalCheckStep, kLocalCheckTurns);
  if (best_e > lead_e + kLocalCheckMargin &&
      std::hypot(best.x - c.x, best.y - c.y) > kLocalCheckMove) {
    lead_h.motion.last.pose = best;
    lead_h.motion.previous.reset();
    lead_h.good_streak = 1;
    step.pose = best;
    return true;
  }
  return false;
}

bool Localiser::verified(const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                         std::size_t lead, const FitnessEvaluator& fine, LocaliserStep& step) {
  // This scan's global search just added candidates: let them be followed first.
  if (step.global_search) return false;
  // Last check before declaring: a fresh global search on this scan must not find a
  // distinct pose that explains it nearly as well (a place the candidates or a wrong hint
  // missed). Always the global grid search, whatever the hint or the search mode: it is
  // the safety net against a wrong confident pose.
  const Hypothesis& h = pool_[lead];
  const Pose2 lead_pose = h.motion.last.pose;
  const float lead_now = evidence(h.value);
  const bool by_contradiction = contradiction_route(h);
  const float lead_contradiction = contradiction(h.value);
  const std::vector<Pose2> fresh =
      search_globally(map, points, /*use_hint=*/false, GlobalSearchMethod::kGrid);
  step.global_search = true;
  scans_since_search_ = 0;
  std::vector<Pose2> rivals;
  for (const Pose2& p : fresh) {
    // A rival is anything outside the tolerance of a right pose: a look-alike 0.8 m and
    // 10 deg away (CSAIL) must stop the declaration as much as one across the map.
    if (same_place(p, lead_pose, kRivalXy, kRivalTheta)) continue;
    const FitnessValue v = fine.evaluate(p);
    if (evidence(v) < static_cast<float>(config_.verify_ambiguity) * lead_now) continue;
    if (by_contradiction && contradicted(contradiction(v), lead_contradiction)) continue;
    rivals.push_back(p);
  }
  if (rivals.empty()) return true;
  add_hypotheses(rivals, map, points, scan);  // may reallocate pool_: h is not used after
  step.hypotheses = pool_.size();
  return false;
}

void Localiser::localise(const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                         LocaliserStep& step) {
  ++searching_scans_;
  follow_hypotheses(map, points, scan);
  // Search (again) when there is nothing to follow or nothing has been declared for a while.
  search_if_due(map, points, scan, step);
  step.hypotheses = pool_.size();
  if (pool_.empty()) return;
  const auto [lead, go] = leader();
  step.pose = pool_[lead].motion.last.pose;
  step.value = pool_[lead].value;
  step.score = pool_[lead].score;
  if (!go) return;
  const FitnessEvaluator fine = fine_evaluator(map, points);
  if (config_.local_check && moved_by_local_check(fine, lead, step)) return;
  if (config_.verify && !verified(map, points, scan, lead, fine, step)) return;
  tracked_ = pool_[lead];
  pool_.clear();
  bad_streak_ = 0;
  state_ = LocaliserState::kTracking;
  step.declared = true;
}

void Localiser::track(const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                      LocaliserStep& step) {
  const TrackResult t = track_scan(config_.tracking, es_, rng_, map, points, scan, tracked_.motion);
  tracked_.motion.previous = tracked_.motion.last;
  tracked_.motion.last = {scan.stamp, t.result.pose};
  if (scan.odometry) tracked_.motion.odometry = scan.odometry;
  tracked_.value = t.result.value;
  step.pose = t.result.pose;
  step.value = t.result.value;
  step.score = evidence(t.result.value);
  const bool bad = t.result.value.agreement() < config_.lost_agreement ||
                   t.result.value.known_share() < config_.lost_known;
  bad_streak_ = bad ? bad_streak_ + 1 : 0;
  if (bad_streak_ >= config_.lost_scans) {
    state_ = LocaliserState::kLost;
    step.lost = true;
    pool_.clear();
    scans_since_search_ = 0;
    research_wait_ = config_.research_every;
    searching_scans_ = config_.hint_scans;  // a hint no longer applies: search globally
  }
}

LocaliserStep Localiser::process(const GridMap& map, const LaserScan& scan) {
  const double t0 = thread_cpu_seconds();
  LocaliserStep step;
  if (map.tile_count() == 0) {
    state_ = LocaliserState::kWaitingForMap;
  } else {
    if (state_ == LocaliserState::kWaitingForMap) state_ = LocaliserState::kLocalising;
    const ScanPoints points = prepare_scan(scan, config_.tracking);
    if (points.size() == 0) {
      // Nothing to match: keep the state, report the last pose.
      step.pose = state_ == LocaliserState::kTracking ? tracked_.motion.last.pose : Pose2{};
    } else if (state_ == LocaliserState::kTracking) {
      track(map, points, scan, step);
    } else {
      localise(map, points, scan, step);
    }
  }
  step.state = state_;
  step.cpu_ms = (thread_cpu_seconds() - t0) * 1e3;
  if (observer_ != nullptr) observer_->on_scan(step, hypothesis_views());
  return step;
}

}  // namespace esfleet
