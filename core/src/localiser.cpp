#include "esfleet/core/localiser.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <stdexcept>

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
  auto check = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(what);
  };
  check(coarse_level >= 0 && coarse_level <= 6, "localise.coarse_level must be in [0, 6]");
  check(step_xy >= 0.0 && std::isfinite(step_xy), "localise.step_xy must be >= 0 (0 = auto)");
  check(step_theta_deg >= 0.0 && step_theta_deg <= 90.0,
        "localise.step_theta must be in [0, 90] degrees (0 = auto)");
  check(coarse_points >= 8, "localise.coarse_points must be >= 8");
  check(free_max_value >= 0.0 && free_max_value < 1.0, "localise.free_max must be in [0, 1)");
  check(candidates >= 1, "localise.candidates must be >= 1");
  check(coarse_keep >= candidates, "localise.coarse_keep must be >= localise.candidates");
  check(mid_level >= 0 && mid_level <= coarse_level,
        "localise.mid_level must be in [0, localise.coarse_level]");
  check(distinct_xy > 0.0 && distinct_theta_deg > 0.0,
        "localise.distinct_xy and distinct_theta must be > 0");
  check(es_restarts >= 1 && es_iterations >= 1,
        "localise.es_restarts and es_iterations must be >= 1");
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
  check(hint_scans >= 1, "localise.hint_scans must be >= 1");
  if (hint) {
    check(hint->radius >= 0.0 && std::isfinite(hint->radius), "hint radius must be >= 0");
    check(hint->angle_deg >= 0.0 && hint->angle_deg <= 180.0,
          "hint angle must be in [0, 180] degrees");
  }
}

float evidence(const FitnessValue& v) {
  return v.n_points > 0 ? static_cast<float>(v.n_hit) / static_cast<float>(v.n_points) : 0.0f;
}

float contradiction(const FitnessValue& v) {
  return v.n_points > 0 ? static_cast<float>(v.n_known - v.n_hit) / static_cast<float>(v.n_points)
                        : 0.0f;
}

EvidencePose best_evidence_near(const FitnessEvaluator& eval, const Pose2& centre, double half_xy,
                                double step_xy, int half_turn_deg) {
  EvidencePose best{centre, -1.0f};
  const int n = static_cast<int>(std::lround(half_xy / step_xy));
  for (int it = -half_turn_deg; it <= half_turn_deg; ++it) {
    for (int iy = -n; iy <= n; ++iy) {
      for (int ix = -n; ix <= n; ++ix) {
        const Pose2 p{centre.x + ix * step_xy, centre.y + iy * step_xy,
                      normalize_angle(centre.theta + it * deg_to_rad(1.0))};
        const float e = evidence(eval.evaluate(p));
        if (e > best.evidence) best = {p, e};
      }
    }
  }
  return best;
}

namespace {

double thread_cpu_ms() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

bool same_place(const Pose2& a, const Pose2& b, double xy, double theta) {
  return std::hypot(a.x - b.x, a.y - b.y) < xy &&
         std::abs(normalize_angle(a.theta - b.theta)) < theta;
}

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

/// Median range of the valid beams (for the heading step).
double median_range(const ScanPoints& points) {
  if (points.range.empty()) return 5.0;
  std::vector<float> r = points.range;
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  return std::max(0.5, static_cast<double>(r[r.size() / 2]));
}

}  // namespace

Localiser::Localiser(LocaliserConfig config)
    : config_(std::move(config)),
      es_(config_.tracking.es),
      hypothesis_es_([this] {
        EsConfig c = config_.tracking.es;
        c.iterations = config_.hypothesis_iterations;
        return c;
      }()),
      rng_(config_.seed) {
  config_.validate();
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

std::vector<Localiser::HypothesisView> Localiser::hypotheses() const {
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

FitnessOptions Localiser::coarse_options(const GridMap& map, const ScanPoints& points) const {
  FitnessOptions o = slam_fitness_options(config_.tracking, false);
  o.level = std::min(config_.coarse_level, map.pyramid_levels());
  o.stride = std::max(1, static_cast<int>(points.size()) / std::max(1, config_.coarse_points));
  o.use_penalty = o.use_penalty && config_.coarse_score != CoarseScore::kSum;
  return o;
}

bool Localiser::good(const FitnessValue& v) const {
  return v.agreement() >= config_.min_agreement && v.known_share() >= config_.min_known;
}

std::vector<Pose2> Localiser::global_candidates(const GridMap& map, const ScanPoints& points,
                                                bool use_hint, GlobalSearch how) {
  const int level = std::min(config_.coarse_level, map.pyramid_levels());
  const double coarse_cell = map.cell_size() * static_cast<double>(1 << level);
  const double step_xy = config_.step_xy > 0.0 ? config_.step_xy : 0.75 * coarse_cell;
  double step_theta = config_.step_theta_deg > 0.0 ? deg_to_rad(config_.step_theta_deg)
                                                   : std::atan2(coarse_cell, median_range(points));
  step_theta = std::clamp(step_theta, deg_to_rad(0.5), deg_to_rad(5.0));
  const PoseHint* hint = use_hint && config_.hint ? &*config_.hint : nullptr;
  if (record_stages_) stages_ = {};

  // Sample positions: cell centres on a step_xy grid over known free cells.
  const int stride = std::max(1, static_cast<int>(std::lround(step_xy / map.cell_size())));
  const int edge = map.tile_edge();
  const double cell = map.cell_size();
  std::vector<Pose2> samples;
  for (const TileKey k : map.tile_keys()) {
    const Tile* t = map.find_tile(k);
    for (int ly = stride / 2; ly < edge; ly += stride) {
      for (int lx = stride / 2; lx < edge; lx += stride) {
        const auto i = static_cast<std::size_t>(ly * edge + lx);
        const std::uint64_t h = t->hit[i], e = t->err[i];
        if (h + e == 0) continue;
        if (static_cast<double>(h) > config_.free_max_value * static_cast<double>(h + e)) continue;
        const double x = (static_cast<double>(k.tx) * edge + lx + 0.5) * cell;
        const double y = (static_cast<double>(k.ty) * edge + ly + 0.5) * cell;
        if (hint && std::hypot(x - hint->pose.x, y - hint->pose.y) > hint->radius + step_xy) {
          continue;
        }
        samples.push_back({x, y, 0.0});
      }
    }
  }
  if (samples.empty()) return {};
  double theta0 = -M_PI, span = 2.0 * M_PI;
  if (hint) {
    theta0 = hint->pose.theta - deg_to_rad(hint->angle_deg);
    span = 2.0 * deg_to_rad(hint->angle_deg);
  }
  if (how == GlobalSearch::kEs) {
    return es_candidates(map, points, samples, theta0, span);
  }
  return grid_candidates(map, points, samples, step_xy, step_theta, theta0, span);
}

std::vector<Pose2> Localiser::grid_candidates(const GridMap& map, const ScanPoints& points,
                                              const std::vector<Pose2>& samples, double step_xy,
                                              double step_theta, double theta0, double span) {
  // The same scores as a FitnessEvaluator with these options, from a dense copy of the level
  // with the end points rotated once per heading (most of a global search's time is here).
  HeadingScorer coarse(map, points, coarse_options(map, points));
  const int headings = std::max(1, static_cast<int>(std::ceil(span / step_theta - 1e-9)) +
                                       (span < 2.0 * M_PI - 1e-9 ? 1 : 0));
  // Best heading per sample position, by the penalised fitness and by the sum of map values
  // (one evaluation gives both).
  struct Scored {
    float score;
    Pose2 pose;
  };
  std::vector<Scored> best_fit(samples.size(), Scored{-1.0f, {}});
  std::vector<Scored> best_sum(samples.size(), Scored{-1.0f, {}});
  for (int h = 0; h < headings; ++h) {
    const double th = normalize_angle(theta0 + h * step_theta);
    coarse.set_heading(th);
    for (std::size_t s = 0; s < samples.size(); ++s) {
      const Pose2 p{samples[s].x, samples[s].y, th};
      const FitnessValue v = coarse.evaluate(p.x, p.y);
      if (v.fitness > best_fit[s].score) best_fit[s] = {v.fitness, p};
      if (v.sum_map > best_sum[s].score) best_sum[s] = {v.sum_map, p};
    }
  }
  const CoarseScore by = config_.coarse_score;
  if (record_stages_) {
    for (const Scored& b : by == CoarseScore::kSum ? best_sum : best_fit) {
      stages_.samples.push_back(b.pose);
      stages_.sample_score.push_back(b.score);
    }
  }
  // The coarse level is blurred (max over 2^L cells): keep many distinct coarse poses, then
  // rank them by their evidence at a finer level over a small window around each.
  std::vector<Scored> coarse_kept;
  const double dth = deg_to_rad(config_.distinct_theta_deg);
  auto keep_best = [&](std::vector<Scored>& best) {
    std::sort(best.begin(), best.end(),
              [](const Scored& a, const Scored& b) { return a.score > b.score; });
    const std::size_t first = coarse_kept.size();
    for (const Scored& c : best) {
      if (!(c.score > 0.0f)) break;
      const bool near = std::any_of(coarse_kept.begin(), coarse_kept.end(), [&](const Scored& k) {
        return same_place(k.pose, c.pose, step_xy * 2.0, dth);
      });
      if (near) continue;
      coarse_kept.push_back(c);
      if (coarse_kept.size() - first >= static_cast<std::size_t>(config_.coarse_keep)) break;
    }
  };
  if (by != CoarseScore::kSum) keep_best(best_fit);
  if (by != CoarseScore::kFitness) keep_best(best_sum);
  FitnessOptions mid_options = slam_fitness_options(config_.tracking, false);
  mid_options.level = std::min(config_.mid_level, map.pyramid_levels());
  const FitnessEvaluator mid(map, points, mid_options);
  const double mid_cell = map.cell_size() * static_cast<double>(1 << mid_options.level);
  const int nxy = std::max(1, static_cast<int>(std::lround(step_xy / mid_cell)));
  std::vector<Scored> ranked;
  for (const Scored& c : coarse_kept) {
    Scored b{-1.0f, c.pose};
    for (int it = -1; it <= 1; ++it) {
      for (int iy = -nxy; iy <= nxy; ++iy) {
        for (int ix = -nxy; ix <= nxy; ++ix) {
          const Pose2 p{c.pose.x + ix * mid_cell, c.pose.y + iy * mid_cell,
                        normalize_angle(c.pose.theta + it * step_theta / 2.0)};
          const float e = evidence(mid.evaluate(p));
          if (e > b.score) b = {e, p};
        }
      }
    }
    ranked.push_back(b);
  }
  std::sort(ranked.begin(), ranked.end(),
            [](const Scored& a, const Scored& b) { return a.score > b.score; });
  std::vector<Pose2> kept;
  for (const Scored& c : ranked) {
    const bool near = std::any_of(kept.begin(), kept.end(), [&](const Pose2& k) {
      return same_place(k, c.pose, config_.distinct_xy, dth);
    });
    if (near) continue;
    kept.push_back(c.pose);
    if (record_stages_) stages_.candidate_evidence.push_back(c.score);
    if (static_cast<int>(kept.size()) >= config_.candidates) break;
  }
  if (record_stages_) {
    for (const Scored& c : coarse_kept) stages_.coarse.push_back(c.pose);
    for (const Scored& c : ranked) {
      stages_.ranked.push_back(c.pose);
      stages_.ranked_evidence.push_back(c.score);
    }
    stages_.candidates = kept;
  }
  // The ES refines each kept candidate at full resolution.
  const FitnessEvaluator fine = fine_evaluator(map, points);
  std::vector<Pose2> out;
  for (const Pose2& c : kept) {
    const auto initial =
        make_initial_population(config_.tracking.es.mu, mid_cell, step_theta / 4.0, rng_);
    const EsResult r = es_.search(fine, c, initial, rng_);
    out.push_back(refine_pose(fine, r.pose, 0.02, deg_to_rad(0.5), 0.001).pose);
  }
  return out;
}

std::vector<Pose2> Localiser::es_candidates(const GridMap& map, const ScanPoints& points,
                                            const std::vector<Pose2>& samples, double theta0,
                                            double span) {
  // The paper's way: the initial population spread over free space and headings; the ES
  // climbs from there. Corrections are absolute poses (centre at the origin).
  const FitnessEvaluator eval(map, points, slam_fitness_options(config_.tracking, false));
  struct Run {
    float fitness;
    Pose2 pose;
  };
  std::vector<Run> runs;
  const auto n = static_cast<std::uint32_t>(samples.size());
  const double cell = map.cell_size();
  for (int r = 0; r < config_.es_restarts; ++r) {
    std::vector<Correction> initial(static_cast<std::size_t>(config_.tracking.es.mu));
    for (Correction& g : initial) {
      const Pose2& s = samples[rng_.below(n)];
      g.dx = s.x + (rng_.uniform() - 0.5) * cell;
      g.dy = s.y + (rng_.uniform() - 0.5) * cell;
      g.dtheta = theta0 + rng_.uniform() * span;
    }
    const EsResult res = es_.search(eval, Pose2{}, initial, rng_, config_.es_iterations);
    runs.push_back({res.value.fitness, res.pose});
  }
  std::sort(runs.begin(), runs.end(),
            [](const Run& a, const Run& b) { return a.fitness > b.fitness; });
  std::vector<Pose2> out;
  const double dth = deg_to_rad(config_.distinct_theta_deg);
  for (const Run& run : runs) {
    const bool near = std::any_of(out.begin(), out.end(), [&](const Pose2& k) {
      return same_place(k, run.pose, config_.distinct_xy, dth);
    });
    if (!near) out.push_back(run.pose);
    if (static_cast<int>(out.size()) >= config_.candidates) break;
  }
  return out;
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

void Localiser::localise(const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                         LocaliserStep& step) {
  ++searching_scans_;
  // Follow every hypothesis with the per-scan tracking step.
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

  // Search (again) when there is nothing to follow or nothing has been declared for a while.
  const bool use_hint = config_.hint && searching_scans_ <= config_.hint_scans;
  const bool any_good = std::any_of(pool_.begin(), pool_.end(),
                                    [](const Hypothesis& h) { return h.good_streak > 0; });
  if (any_good) research_wait_ = config_.research_every;
  if (pool_.empty() || (!any_good && scans_since_search_ >= research_wait_)) {
    // A search that follows scans where nothing matched well: wait longer for the next one.
    if (!pool_.empty()) research_wait_ = std::min(2 * research_wait_, config_.research_every_max);
    add_hypotheses(global_candidates(map, points, use_hint, config_.global), map, points, scan);
    scans_since_search_ = 0;
    step.global_search = true;
  } else {
    ++scans_since_search_;
  }
  step.hypotheses = pool_.size();
  if (pool_.empty()) return;
  std::size_t lead = 0;
  for (std::size_t i = 1; i < pool_.size(); ++i) {
    if (pool_[i].score > pool_[lead].score) lead = i;
  }
  auto ready = [&](std::size_t i) {
    const Hypothesis& c = pool_[i];
    const bool moved = c.travel >= config_.min_travel || c.turn >= deg_to_rad(config_.min_turn_deg);
    if (c.good_streak < config_.confirm_scans || !moved || !(c.score > 0.0f)) return false;
    for (std::size_t j = 0; j < pool_.size(); ++j) {
      if (j != i && !clear_of(c, pool_[j])) return false;
    }
    return true;
  };
  bool go = ready(lead);
  if (!go && config_.contradiction_factor > 0.0) {
    // The contradiction route: another hypothesis may be clear of all the others.
    for (std::size_t i = 0; i < pool_.size() && !go; ++i) {
      if (i != lead && contradiction_route(pool_[i]) && ready(i)) {
        lead = i;
        go = true;
      }
    }
  }
  const Hypothesis& h = pool_[lead];
  step.pose = h.motion.last.pose;
  step.value = h.value;
  step.score = h.score;
  if (!go) return;
  const FitnessEvaluator fine = fine_evaluator(map, points);
  if (config_.local_check) {
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
      return;
    }
  }
  if (config_.verify) {
    // This scan's global search just added candidates: let them be followed first.
    if (step.global_search) return;
    // Last check before declaring: a fresh global search on this scan must not find a
    // distinct pose that explains it nearly as well (a place the candidates or a wrong hint
    // missed). Always the global grid search, whatever the hint or the search mode: it is
    // the safety net against a wrong confident pose.
    const Pose2 lead_pose = h.motion.last.pose;
    const float lead_now = evidence(h.value);
    const bool by_contradiction = contradiction_route(h);
    const float lead_contradiction = contradiction(h.value);
    const std::vector<Pose2> fresh =
        global_candidates(map, points, /*use_hint=*/false, GlobalSearch::kGrid);
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
    if (!rivals.empty()) {
      add_hypotheses(rivals, map, points, scan);  // may reallocate pool_: h is not used after
      step.hypotheses = pool_.size();
      return;
    }
  }
  tracked_ = h;
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
  const double t0 = thread_cpu_ms();
  LocaliserStep step;
  if (map.tile_count() == 0) {
    state_ = LocaliserState::kWaitingForMap;
  } else {
    if (state_ == LocaliserState::kWaitingForMap) state_ = LocaliserState::kLocalising;
    const ScanPoints points =
        prepare_scan(scan, config_.tracking.min_range, config_.tracking.max_range);
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
  step.cpu_ms = thread_cpu_ms() - t0;
  return step;
}

}  // namespace esfleet
