#include "esfleet/core/global_search.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "esfleet/core/evidence.hpp"

namespace esfleet {

void GlobalSearchConfig::validate() const {
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
}

namespace {

/// Median range of the valid beams (for the heading step).
double median_range(const ScanPoints& points) {
  if (points.range.empty()) return 5.0;
  std::vector<float> r = points.range;
  std::nth_element(r.begin(), r.begin() + static_cast<std::ptrdiff_t>(r.size() / 2), r.end());
  return std::max(0.5, static_cast<double>(r[r.size() / 2]));
}

}  // namespace

GlobalSearch::GlobalSearch(GlobalSearchConfig config, const TrackingConfig& tracking)
    : config_(config), tracking_(tracking), es_(tracking.es) {
  config_.validate();
}

FitnessOptions GlobalSearch::coarse_options(const GridMap& map, const ScanPoints& points) const {
  FitnessOptions o = slam_fitness_options(tracking_, false);
  o.level = std::min(config_.coarse_level, map.pyramid_levels());
  o.stride = std::max(1, static_cast<int>(points.size()) / std::max(1, config_.coarse_points));
  o.use_penalty = o.use_penalty && config_.coarse_score != CoarseScore::kSum;
  return o;
}

std::vector<Pose2> GlobalSearch::run(const GridMap& map, const ScanPoints& points,
                                     const PoseHint* hint, GlobalSearchMethod how, Rng& rng,
                                     SearchStages* stages) const {
  const int level = std::min(config_.coarse_level, map.pyramid_levels());
  const double coarse_cell = map.cell_size() * static_cast<double>(1 << level);
  const double step_xy = config_.step_xy > 0.0 ? config_.step_xy : 0.75 * coarse_cell;
  double step_theta = config_.step_theta_deg > 0.0 ? deg_to_rad(config_.step_theta_deg)
                                                   : std::atan2(coarse_cell, median_range(points));
  step_theta = std::clamp(step_theta, deg_to_rad(0.5), deg_to_rad(5.0));
  if (stages) *stages = {};

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
  if (how == GlobalSearchMethod::kEs) {
    return es_candidates(map, points, samples, theta0, span, rng);
  }
  return grid_candidates(map, points, samples, step_xy, step_theta, theta0, span, rng, stages);
}

std::vector<Pose2> GlobalSearch::grid_candidates(const GridMap& map, const ScanPoints& points,
                                                 const std::vector<Pose2>& samples, double step_xy,
                                                 double step_theta, double theta0, double span,
                                                 Rng& rng, SearchStages* stages) const {
  // The same scores as a FitnessEvaluator with these options, from a dense copy of the level
  // with the end points rotated once per heading (most of a global search's time is here).
  const FitnessOptions coarse_opts = coarse_options(map, points);
  HeadingScorer coarse(map, points, coarse_opts);
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
  if (stages) {
    stages->coarse_options = coarse_opts;
    for (const Scored& b : by == CoarseScore::kSum ? best_sum : best_fit) {
      stages->samples.push_back(b.pose);
      stages->sample_score.push_back(b.score);
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
  FitnessOptions mid_options = slam_fitness_options(tracking_, false);
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
    if (stages) stages->candidate_evidence.push_back(c.score);
    if (static_cast<int>(kept.size()) >= config_.candidates) break;
  }
  if (stages) {
    for (const Scored& c : coarse_kept) stages->coarse.push_back(c.pose);
    for (const Scored& c : ranked) {
      stages->ranked.push_back(c.pose);
      stages->ranked_evidence.push_back(c.score);
    }
    stages->candidates = kept;
  }
  // The ES refines each kept candidate at full resolution.
  const FitnessEvaluator fine(
      map, points,
      slam_fitness_options(tracking_, tracking_.interpolation != Interpolation::kNone));
  std::vector<Pose2> out;
  for (const Pose2& c : kept) {
    const auto initial = make_initial_population(tracking_.es.mu, mid_cell, step_theta / 4.0, rng);
    const EsResult r = es_.search(fine, c, initial, rng);
    out.push_back(refine_pose(fine, r.pose, 0.02, deg_to_rad(0.5), 0.001).pose);
  }
  return out;
}

std::vector<Pose2> GlobalSearch::es_candidates(const GridMap& map, const ScanPoints& points,
                                               const std::vector<Pose2>& samples, double theta0,
                                               double span, Rng& rng) const {
  // The paper's way: the initial population spread over free space and headings; the ES
  // climbs from there. Corrections are absolute poses (centre at the origin).
  const FitnessEvaluator eval(map, points, slam_fitness_options(tracking_, false));
  struct Run {
    float fitness;
    Pose2 pose;
  };
  std::vector<Run> runs;
  const auto n = static_cast<std::uint32_t>(samples.size());
  const double cell = map.cell_size();
  for (int r = 0; r < config_.es_restarts; ++r) {
    std::vector<Correction> initial(static_cast<std::size_t>(tracking_.es.mu));
    for (Correction& g : initial) {
      const Pose2& s = samples[rng.below(n)];
      g.dx = s.x + (rng.uniform() - 0.5) * cell;
      g.dy = s.y + (rng.uniform() - 0.5) * cell;
      g.dtheta = theta0 + rng.uniform() * span;
    }
    const EsResult res = es_.search(eval, Pose2{}, initial, rng, config_.es_iterations);
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

}  // namespace esfleet
