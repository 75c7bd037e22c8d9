#include "esfleet/core/recovery.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <string>

#include "coarse_grid.hpp"

namespace esfleet {

void RecoveryConfig::validate() const {
  auto check = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("slam.recovery_" + what);
  };
  auto in01 = [](double v) { return v >= 0.0 && v <= 1.0; };
  check(in01(weak_agreement), "weak_agreement must be in [0, 1]");
  check(in01(min_known), "min_known must be in [0, 1]");
  check(in01(lost_view_known), "lost_view_known must be in [0, 1]");
  check(in01(min_gain) && in01(min_gain_fair), "min_gain and min_gain_fair must be in [0, 1]");
  check(fair_short_jump >= 0.0 && std::isfinite(fair_short_jump),
        "fair_short_jump must be a finite number >= 0");
  check(gain_per_window >= 0.0 && gain_per_window_fair >= 0.0,
        "gain_per_window and gain_per_window_fair must be >= 0");
  check(clear_gain >= 0.0 && clear_gain <= 3.0, "clear_gain must be in [0, 3] (0 = no cap)");
  check(in01(min_hits), "min_hits must be in [0, 1] (0 = never)");
  check(tolerance >= 0 && tolerance <= 3, "tolerance must be in [0, 3] cells");
  check(in01(insert_min_agreement), "insert_min_agreement must be in [0, 1]");
  check(in01(settled_agreement), "settled_agreement must be in [0, 1]");
  check(in01(settled_known), "settled_known must be in [0, 1]");
  check(wide_motion_xy >= 0.0 && wide_motion_theta_deg >= 0.0,
        "wide_motion_xy and wide_motion_theta must be >= 0 (0 = off)");
  check(max_speed >= 0.0 && std::isfinite(max_speed), "max_speed must be >= 0 (0 = off)");
  check(window_scale_xy > 0.0 && window_scale_theta_deg > 0.0,
        "window_scale_xy and window_scale_theta must be > 0");
  check(window_min_scale > 0.0 && window_min_scale <= 1.0, "window_min_scale must be in (0, 1]");
  check(weak_min_scale >= 0.0 && weak_min_scale <= 1.0, "weak_min_scale must be in [0, 1]");
  check(odometry_window_xy >= 0.0 && std::isfinite(odometry_window_xy),
        "odometry_window_xy must be >= 0 (0 = off)");
  check(odometry_window_theta_deg > 0.0 && odometry_window_theta_deg <= 180.0,
        "odometry_window_theta must be in (0, 180] degrees");
  check(odometry_window_frac >= 0.0 && std::isfinite(odometry_window_frac),
        "odometry_window_frac must be >= 0");
  check(free_penalty >= 0.0 && free_penalty <= 10.0, "free_penalty must be in [0, 10]");
  check(window_xy > 0.0 && window_xy <= 20.0, "window_xy must be in (0, 20] metres");
  check(window_theta_deg > 0.0 && window_theta_deg <= 180.0,
        "window_theta must be in (0, 180] degrees");
  check(coarse_level >= 0 && coarse_level <= 4, "coarse_level must be in [0, 4]");
  check(points >= 8 && points <= 10000, "points must be in [8, 10000]");
  check(max_range > 0.0 && std::isfinite(max_range), "max_range must be > 0");
  check(candidates >= 1 && candidates <= 100, "candidates must be in [1, 100]");
  check(more_candidates >= candidates && more_candidates <= 100,
        "more_candidates must be in [candidates, 100]");
  check(min_hits_ratio >= 0.0 && std::isfinite(min_hits_ratio), "min_hits_ratio must be >= 0");
  check(more_below >= -2.0 && more_below <= 1.0, "more_below must be in [-2, 1]");
  check(distinct_xy >= 0.0 && distinct_theta_deg >= 0.0,
        "distinct_xy and distinct_theta must be >= 0");
}

bool weak_match(const RecoveryConfig& config, const FitnessValue& v) {
  if (v.n_points == 0) return false;
  return (v.known_share() >= config.min_known && v.agreement() < config.weak_agreement) ||
         v.known_share() < config.lost_view_known;
}

double gain_needed(const RecoveryConfig& config, bool weak, double d) {
  const double needed = weak ? config.min_gain + config.gain_per_window * d
                             : config.min_gain_fair + config.gain_per_window_fair * d;
  return config.clear_gain > 0.0 ? std::min(needed, config.clear_gain) : needed;
}

bool judged_as_weak(const RecoveryConfig& config, bool weak, double jump_xy, double moved) {
  return weak || jump_xy <= config.fair_short_jump * moved;
}

bool overlaps_enough(const RecoveryConfig& config, const FitnessValue& recovered,
                     const FitnessValue& tracked) {
  if (recovered.known_share() >= config.min_known) return true;
  return config.min_hits > 0.0 && recovered.n_points > 0 &&
         recovered.n_hit >= config.min_hits * recovered.n_points &&
         recovered.n_hit >= config.min_hits_ratio * tracked.n_hit;
}

namespace {

constexpr double kPi = std::numbers::pi;

using coarse_grid::PooledWindow;

inline std::int32_t floor_f(float v) {
  const auto i = static_cast<std::int32_t>(v);
  return i - static_cast<std::int32_t>(v < static_cast<float>(i));
}

using coarse_grid::best_distinct;
using coarse_grid::Scored;

/// The end points the coarse and fine stages score, in cell units (at most config.points of
/// those within config.max_range, evenly strided; none when fewer than 8 are), and the same
/// rotated by one heading at a time.
struct CellPoints {
  std::vector<float> x, y, range;
  std::vector<float> rx, ry;  ///< rotated by the heading of the last rotate()

  void rotate(double theta) {
    const auto c = static_cast<float>(std::cos(theta)), s = static_cast<float>(std::sin(theta));
    for (std::size_t j = 0; j < x.size(); ++j) {
      rx[j] = c * x[j] - s * y[j];
      ry[j] = s * x[j] + c * y[j];
    }
  }
};

CellPoints sample_points(const RecoveryConfig& config, const ScanPoints& points, double inv_cell) {
  std::vector<std::size_t> near;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (points.range[i] <= config.max_range) near.push_back(i);
  }
  CellPoints out;
  if (near.size() < 8) return out;
  const double stride = static_cast<double>(near.size()) / config.points;
  for (int j = 0; j < config.points; ++j) {
    const auto k = static_cast<std::size_t>(stride > 1.0 ? std::floor(j * stride) : j);
    if (k >= near.size()) break;
    out.x.push_back(static_cast<float>(points.x[near[k]] * inv_cell));
    out.y.push_back(static_cast<float>(points.y[near[k]] * inv_cell));
    out.range.push_back(points.range[near[k]]);
  }
  out.rx.resize(out.x.size());
  out.ry.resize(out.x.size());
  return out;
}

/// Fine: the best of every cell and a third of the coarse heading step within `fxy` cells and
/// one coarse heading step around the coarse pose `b`, scored at full resolution.
Scored fine_best(const PooledWindow& window, CellPoints& pts, const Scored& b, int fxy,
                 double step_theta, double cell_size) {
  const double inv_cell = 1.0 / cell_size;
  const auto side = static_cast<std::size_t>(2 * fxy + 1);
  std::vector<float> sums(side * side);
  Scored top{-1.0f, b.pose};
  for (int it = -3; it <= 3; ++it) {
    const double theta = normalize_angle(b.pose.theta + it * step_theta / 3.0);
    pts.rotate(theta);
    coarse_grid::fine_sums(window, b.pose.x * inv_cell, b.pose.y * inv_cell, pts.rx.data(),
                           pts.ry.data(), pts.rx.size(), fxy, sums.data());
    for (int iy = -fxy; iy <= fxy; ++iy) {
      for (int ix = -fxy; ix <= fxy; ++ix) {
        const float sum =
            sums[static_cast<std::size_t>(iy + fxy) * side + static_cast<std::size_t>(ix + fxy)];
        if (sum > top.score) {
          top = {sum, {b.pose.x + ix * cell_size, b.pose.y + iy * cell_size, theta}};
        }
      }
    }
  }
  return top;
}

}  // namespace

Consistency consistency(const GridMap& map, const ScanPoints& points, const Pose2& pose,
                        int tolerance) {
  Consistency out;
  const std::size_t n = points.size();
  if (n == 0 || beyond_any_map(pose.x / map.cell_size(), pose.y / map.cell_size())) return out;
  const GridMap::Lookup lookup = map.lookup(0);
  const GridMap::Lookup::Addressing a = lookup.addressing();
  const double inv_cell = 1.0 / map.cell_size();
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double ox = pose.x * inv_cell, oy = pose.y * inv_cell;
  auto score_cell = [&](std::int32_t cx, std::int32_t cy) {
    return lookup.tile(a.slot(cx, cy))[a.offset(cx, cy)];
  };
  auto score_at = [&](double x, double y) {
    return score_cell(static_cast<std::int32_t>(std::floor(x)),
                      static_cast<std::int32_t>(std::floor(y)));
  };
  // A cell with hits within `tolerance` cells of (cx, cy).
  auto hit_near = [&](std::int32_t cx, std::int32_t cy) {
    for (std::int32_t dy = -tolerance; dy <= tolerance; ++dy) {
      for (std::int32_t dx = -tolerance; dx <= tolerance; ++dx) {
        if (score_cell(cx + dx, cy + dy) > 0.0f) return true;
      }
    }
    return false;
  };
  // A beam looks through a wall when a cell more than `margin` cells before its end point was
  // seen occupied more often than free.
  constexpr double kMargin = 3.0;
  // The walk visits only the samples within the tiles' bounding box (plus one each side): every
  // cell outside it is unknown, so no sample there can look through a wall. A scan reading
  // 999 m walked 20 000 cells per beam.
  const GridMap::Bounds box = map.tile_bounds();
  if (box.empty) return out;
  auto inside = [](double o, double d, double lo, double hi, double& t0, double& t1) {
    if (d == 0.0) {
      if (o < lo || o >= hi) t1 = -1.0;  // parallel and outside: no sample inside
      return;
    }
    const double ta = (lo - o) / d, tb = (hi - o) / d;
    t0 = std::max(t0, std::min(ta, tb));
    t1 = std::min(t1, std::max(ta, tb));
  };
  int hit = 0, free = 0, through = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double ex = points.x[i] * inv_cell, ey = points.y[i] * inv_cell;
    const double wx = ox + c * ex - s * ey, wy = oy + s * ex + c * ey;
    const auto cx = static_cast<std::int32_t>(std::floor(wx));
    const auto cy = static_cast<std::int32_t>(std::floor(wy));
    const float v = score_cell(cx, cy);
    const bool on_hit = v > 0.0f || (tolerance > 0 && hit_near(cx, cy));
    hit += on_hit;
    free += !on_hit && v == 0.0f;
    const double len = std::hypot(ex, ey);
    const int steps = static_cast<int>(len - kMargin);
    if (steps <= 1) continue;
    const double dx = (wx - ox) / len, dy = (wy - oy) / len;
    double t0 = 0.0, t1 = steps;
    inside(ox, dx, box.min.x, box.max.x + 1.0, t0, t1);
    inside(oy, dy, box.min.y, box.max.y + 1.0, t0, t1);
    if (t0 > t1) continue;
    const int k_end = std::min(steps, static_cast<int>(t1) + 2);
    for (int k = std::max(1, static_cast<int>(t0) - 1); k < k_end; ++k) {
      if (score_at(ox + dx * k, oy + dy * k) > 0.5f) {
        ++through;
        break;
      }
    }
  }
  const auto nf = static_cast<float>(n);
  out.evidence = static_cast<float>(hit) / nf;
  out.contradiction = static_cast<float>(free) / nf;
  out.see_through = static_cast<float>(through) / nf;
  return out;
}

RecoveryResult recover_pose(const RecoveryConfig& config, const TrackingConfig& tracking,
                            const EvolutionStrategy& es, Rng& rng, const GridMap& map,
                            const ScanPoints& points, const Pose2& centre) {
  RecoveryResult out;
  out.result.pose = centre;
  const double inv_cell = 1.0 / map.cell_size();
  if (beyond_any_map(centre.x * inv_cell, centre.y * inv_cell)) return out;
  CellPoints pts = sample_points(config, points, inv_cell);
  const std::size_t n = pts.x.size();
  if (n == 0) return out;
  const std::vector<float>& pr = pts.range;
  std::vector<float> sorted_range = pr;
  std::nth_element(sorted_range.begin(), sorted_range.begin() + n / 2, sorted_range.end());
  const double median_range = std::max(1.0, static_cast<double>(sorted_range[n / 2]));
  const double far = *std::max_element(pr.begin(), pr.end());

  // The window of the map any scored end point can reach.
  const auto factor = std::int32_t{1} << config.coarse_level;
  const double reach = (config.window_xy + far) * inv_cell + 2.0;
  const double cx = centre.x * inv_cell, cy = centre.y * inv_cell;
  // Only where the tiles are: every cell outside them is unknown, and a pooled block of unknown
  // cells is worth 0, as is a block outside the window. The window is whole blocks, so the
  // blocks it keeps are pooled as without the clip. (A scan reading 999 m made the window
  // 40 000 cells wide: 1.6e9 look-ups per recovery.)
  const GridMap::Bounds tiles = map.tile_bounds();
  if (tiles.empty) return out;  // nothing known
  const std::int32_t x_min = std::max(floor_f(static_cast<float>(cx - reach)), tiles.min.x);
  const std::int32_t y_min = std::max(floor_f(static_cast<float>(cy - reach)), tiles.min.y);
  const std::int32_t x_max = std::min(floor_f(static_cast<float>(cx + reach)), tiles.max.x);
  const std::int32_t y_max = std::min(floor_f(static_cast<float>(cy + reach)), tiles.max.y);
  if (x_min > x_max || y_min > y_max) return out;  // nothing known in reach
  const PooledWindow window(map, x_min, y_min, x_max, y_max, factor,
                            static_cast<float>(config.free_penalty));
  if (!window.any_hit()) return out;

  // Coarse: positions in steps of half a pooled block, headings that move an end point at the
  // median range by about one pooled block.
  const double coarse_cell = map.cell_size() * factor;
  const double step_xy = coarse_cell / 2.0;
  const double step_theta =
      std::clamp(std::atan2(coarse_cell, median_range), deg_to_rad(0.5), deg_to_rad(3.0));
  const int nxy = static_cast<int>(std::ceil(config.window_xy / step_xy));
  // Headings: +-window_theta around the centre's (all of them if that covers the circle).
  const double half = deg_to_rad(config.window_theta_deg);
  double lo = -half, hi = half;
  if (hi - lo > 2.0 * kPi - step_theta) {
    lo = -kPi;
    hi = kPi - step_theta;
  }
  const int th_lo = static_cast<int>(std::floor(lo / step_theta));
  const int th_hi = static_cast<int>(std::ceil(hi / step_theta));
  const std::size_t side = static_cast<std::size_t>(2 * nxy + 1);
  const std::size_t per_heading = side * side;
  const coarse_grid::GridScorer scorer(window, cx, cy, nxy);
  // Each heading's scores are offered as they are summed (kept only while among the best).
  const auto headings = static_cast<std::size_t>(th_hi - th_lo + 1);
  std::vector<float> heading_scores(per_heading);
  const auto score_all = [&](coarse_grid::BestScores& top) {
    for (int it = th_lo; it <= th_hi; ++it) {
      pts.rotate(normalize_angle(centre.theta + it * step_theta));
      scorer.score(pts.rx.data(), pts.ry.data(), n, heading_scores.data());
      top.add(heading_scores.data(), per_heading,
              static_cast<std::uint64_t>(it - th_lo) * per_heading);
    }
  };
  // Index i: heading th_lo + i / per_heading, then row iy, then column ix, each from -nxy.
  const auto pose_of = [&](std::uint64_t i) {
    const auto it = th_lo + static_cast<int>(i / per_heading);
    const auto iy = static_cast<int>(i % per_heading / side) - nxy;
    const auto ix = static_cast<int>(i % side) - nxy;
    return Pose2{centre.x + ix * step_xy, centre.y + iy * step_xy,
                 normalize_angle(centre.theta + it * step_theta)};
  };
  out.coarse_poses = static_cast<std::int64_t>(headings * per_heading);
  // The greedy pass for 64 distinct poses read at most the best 2048 scores in every search of
  // the key-scan log and fr079 every 8th scan (seed 1, laser only; of about 60 000).
  const auto keep = static_cast<std::size_t>(std::max(config.candidates, config.more_candidates));
  const std::vector<Scored> best =
      best_distinct(score_all, keep, config.distinct_xy, deg_to_rad(config.distinct_theta_deg),
                    pose_of, std::max<std::size_t>(1024, 64 * keep));
  if (best.empty()) return out;

  // Fine: each coarse pose of [first, last) searched again within one coarse step, best first.
  const int fxy = factor / 2;
  const auto fine_stage = [&](std::size_t first, std::size_t last) {
    std::vector<Scored> fine;
    for (std::size_t i = first; i < last; ++i) {
      out.coarse.push_back(best[i].pose);
      fine.push_back(fine_best(window, pts, best[i], fxy, step_theta, map.cell_size()));
    }
    std::stable_sort(fine.begin(), fine.end(),
                     [](const Scored& a, const Scored& b) { return a.score > b.score; });
    return fine;
  };

  // Each candidate polished at full resolution with the tracking's fitness, then judged by its
  // consistency with the map (which also sees beams through walls); the best one is finished
  // by the ES (no motion prior: the prediction is what failed) and polished. (A prior on the
  // distance from the prediction, 0.1 per metre, measured worse on the key-scan log: seeds
  // 1-3 5.2-9.6 m against 0.4-1.7 m.)
  const FitnessEvaluator eval(
      map, points, slam_fitness_options(tracking, tracking.interpolation == Interpolation::kAll));
  const FitnessEvaluator fine_eval(
      map, points, slam_fitness_options(tracking, tracking.interpolation != Interpolation::kNone));
  Pose2 start = best.front().pose;
  float best_score = -10.0f;
  const auto judge = [&](const std::vector<Scored>& fine) {
    for (const Scored& f : fine) {
      const EsResult r = refine_pose(fine_eval, f.pose, map.cell_size(), step_theta / 3.0, 0.005);
      const float sc = consistency(map, points, r.pose, config.tolerance).score();
      if (sc > best_score) {
        best_score = sc;
        start = r.pose;
      }
    }
  };
  const std::size_t first = std::min(best.size(), static_cast<std::size_t>(config.candidates));
  judge(fine_stage(0, first));
  if (best_score < config.more_below) {
    // One of them is taken only if it fits: among three times as many poses that fit poorly, a
    // slightly less inconsistent one is as likely wrong (CSAIL every 5th scan, seeds 2 and 4).
    const Pose2 first_start = start;
    judge(fine_stage(first, best.size()));
    if (best_score < config.more_below) start = first_start;
  }
  const auto initial =
      make_initial_population(tracking.es.mu, map.cell_size(), step_theta / 3.0, rng);
  out.result = es.search(eval, start, initial, rng);
  if (tracking.refine) {
    out.result = refine_pose(fine_eval, out.result.pose, 0.02, deg_to_rad(0.5), 0.001);
  }
  return out;
}

}  // namespace esfleet
