#include "esfleet/core/loop_closure.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "esfleet/core/es_search.hpp"
#include "esfleet/core/window_search.hpp"

namespace esfleet {

void LoopClosureConfig::validate() const {
  auto positive = [](double v, const char* name) {
    if (!(v > 0.0) || !std::isfinite(v)) {
      throw std::invalid_argument(std::string("loop.") + name + " must be > 0");
    }
  };
  if (every < 1) throw std::invalid_argument("loop.every must be >= 1");
  if (cooldown < 0) throw std::invalid_argument("loop.cooldown must be >= 0");
  if (max_submap_scans < 1) throw std::invalid_argument("loop.max_submap_scans must be >= 1");
  if (defer_keys < 0 || defer_keys > every) {
    throw std::invalid_argument("loop.defer_keys must be in [0, loop.every]");
  }
  positive(min_travel, "min_travel");
  positive(search_radius, "search_radius");
  positive(submap_radius, "submap_radius");
  positive(window_xy, "window_xy");
  if (!(window_max_xy >= 0.0) || !std::isfinite(window_max_xy)) {
    throw std::invalid_argument("loop.window_max_xy must be >= 0");
  }
  positive(window_theta_deg, "window_theta_deg");
  if (!(degenerate_ratio >= 0.0 && degenerate_ratio < 1.0)) {
    throw std::invalid_argument("loop.degenerate_ratio must be in [0, 1)");
  }
  positive(sigma_xy, "sigma_xy");
  positive(sigma_theta_deg, "sigma_theta_deg");
  if (final_pass) {
    if (final_every < 1) throw std::invalid_argument("loop.final_every must be >= 1");
    if (final_rounds < 1) throw std::invalid_argument("loop.final_rounds must be >= 1");
    if (final_icp_neighbours < 0) {
      throw std::invalid_argument("loop.final_icp_neighbours must be >= 0");
    }
    if (final_icp_neighbours > 0) {
      positive(final_icp_max_distance, "final_icp_max_distance");
      icp.validate();
    }
    if (final_max_submap_scans < 1) {
      throw std::invalid_argument("loop.final_max_submap_scans must be >= 1");
    }
    positive(final_window_xy, "final_window_xy");
    positive(final_window_theta_deg, "final_window_theta_deg");
    positive(final_submap_radius, "final_submap_radius");
    positive(final_rival_distance, "final_rival_distance");
    positive(final_max_ambiguity, "final_max_ambiguity");
    positive(final_max_edge_chi2, "final_max_edge_chi2");
    if (!(final_degenerate_ratio >= 0.0 && final_degenerate_ratio < 1.0)) {
      throw std::invalid_argument("loop.final_degenerate_ratio must be in [0, 1)");
    }
  }
}

double loop_search_window_xy(const LoopClosureConfig& c, double travel) {
  if (!(c.window_max_xy > c.window_xy)) return c.window_xy;
  return std::clamp(c.drift_floor_xy + c.drift_rate_xy * travel, c.window_xy, c.window_max_xy);
}

namespace {
bool same_scan(const SubmapScan& a, const SubmapScan& b) {
  // Bitwise pose equality: a scan moved by any amount is cast again.
  return a.points == b.points && a.pose.x == b.pose.x && a.pose.y == b.pose.y &&
         a.pose.theta == b.pose.theta;
}
}  // namespace

void SubmapCache::cast(const SubmapScan& scan, const MapUpdateConfig& config, bool remove) {
  update_map(*map_, *scan.points, scan.pose, config, remove, /*commit=*/false);
  ++scans_cast_;
}

void SubmapCache::trim() {
  if (map_ && map_->tile_count() > max_kept_tiles_) clear();
}

const GridMap& SubmapCache::build(const std::vector<SubmapScan>& scans,
                                  const GridMapConfig& map_config,
                                  const MapUpdateConfig& update_config) {
  std::vector<bool> kept_new(scans.size(), false);
  std::vector<const SubmapScan*> removed;
  for (const SubmapScan& old : members_) {
    bool kept = false;
    for (std::size_t i = 0; i < scans.size() && !kept; ++i) {
      if (!kept_new[i] && same_scan(old, scans[i])) kept = kept_new[i] = true;
    }
    if (!kept) removed.push_back(&old);
  }
  const auto kept = static_cast<std::size_t>(std::count(kept_new.begin(), kept_new.end(), true));
  const std::size_t added = scans.size() - kept;
  // From scratch when that casts fewer scans, or when tiles only removed scans touched have
  // grown the submap by an eighth (they cost memory and the coarse search's dense copy).
  const bool fresh = !map_ || removed.size() + added >= scans.size() ||
                     map_->tile_count() > fresh_tiles_ + fresh_tiles_ / 8 + 1;
  if (fresh) {
    map_ = std::make_unique<GridMap>(map_config);
    for (const SubmapScan& s : scans) cast(s, update_config, false);
  } else {
    for (const SubmapScan* s : removed) cast(*s, update_config, true);
    for (std::size_t i = 0; i < scans.size(); ++i) {
      if (!kept_new[i]) cast(scans[i], update_config, false);
    }
  }
  map_->commit_update();
  if (fresh) fresh_tiles_ = map_->tile_count();
  members_ = scans;
  return *map_;
}

std::optional<LoopMatch> find_loop_closure(const std::vector<KeyScan>& keys,
                                           const std::vector<Pose2>& poses,
                                           const ScanPoints& points, const Pose2& estimate,
                                           double path_length, const LoopClosureConfig& config,
                                           const GridMapConfig& map_config,
                                           const MapUpdateConfig& update_config,
                                           const FitnessOptions& fitness, SubmapCache* cache) {
  // Old scans near the estimate, nearest first.
  std::vector<std::pair<double, std::size_t>> near;
  bool trigger = false;
  for (std::size_t k = 0; k < keys.size(); ++k) {
    if (path_length - keys[k].path_length < config.min_travel) continue;
    const double d = std::hypot(poses[k].x - estimate.x, poses[k].y - estimate.y);
    if (d <= config.search_radius) trigger = true;
    if (d <= config.submap_radius) near.emplace_back(d, k);
  }
  if (!trigger || near.size() < 3) return std::nullopt;
  std::sort(near.begin(), near.end());
  if (near.size() > static_cast<std::size_t>(config.max_submap_scans)) {
    near.resize(static_cast<std::size_t>(config.max_submap_scans));
  }

  constexpr int kCoarseLevel = 2;
  GridMapConfig submap_config = map_config;
  submap_config.pyramid_levels = std::max(map_config.pyramid_levels, kCoarseLevel);
  std::vector<SubmapScan> scans;
  scans.reserve(near.size());
  for (const auto& [d, k] : near) scans.push_back({keys[k].points, poses[k]});
  SubmapCache local;
  const GridMap& submap =
      (cache != nullptr ? *cache : local).build(scans, submap_config, update_config);

  // The window on the coarse level: translation steps of half a coarse cell, rotation steps
  // that move a 10 m beam end by about one coarse cell; the best candidate and its rival found
  // by branch and bound (the brute-force result, bit for bit).
  FitnessOptions coarse_options = fitness;
  coarse_options.level = kCoarseLevel;
  coarse_options.stride = 2;
  coarse_options.interpolate = false;
  const double coarse_cell = map_config.cell_size * (1 << kCoarseLevel);
  SearchWindow window;
  window.centre = estimate;
  window.step_xy = coarse_cell / 2.0;
  window.step_theta = std::atan2(coarse_cell, 10.0);
  window.n_xy = static_cast<int>(std::ceil(config.window_xy / window.step_xy));
  window.n_theta =
      static_cast<int>(std::ceil(deg_to_rad(config.window_theta_deg) / window.step_theta));
  const std::optional<WindowMatch> best = search_window(
      submap, points, coarse_options, window, config.rival_distance, config.max_ambiguity);
  if (!best) return std::nullopt;
  LoopMatch match;
  match.ambiguity = static_cast<double>(best->rival) / static_cast<double>(best->score);
  match.submap_scans = near.size();
  if (match.ambiguity > config.max_ambiguity) return std::nullopt;

  FitnessOptions fine_options = fitness;
  fine_options.level = 0;
  fine_options.stride = 1;
  const FitnessEvaluator fine(submap, points, fine_options);
  const EsResult polished = refine_pose(fine, best->pose, window.step_xy, window.step_theta, 0.001);
  match.pose = polished.pose;
  match.value = polished.value;
  if (config.degenerate_ratio > 0.0) {
    // Curvature over two cells: the bilinear fitness is flat within one.
    const Flattest flat =
        flattest_direction(fine, match.pose, match.value.fitness, 2.0 * map_config.cell_size);
    if (flat.curved && flat.ratio < config.degenerate_ratio) {
      // The estimate's position along the flattest direction, the match's across it.
      const double along =
          flat.vx * (match.pose.x - estimate.x) + flat.vy * (match.pose.y - estimate.y);
      match.pose.x -= along * flat.vx;
      match.pose.y -= along * flat.vy;
      match.value = fine.evaluate(match.pose);
    }
  }
  const double known = match.value.n_points > 0 ? static_cast<double>(match.value.n_known) /
                                                      static_cast<double>(match.value.n_points)
                                                : 0.0;
  if (match.value.agreement() < config.min_agreement || known < config.min_known) {
    return std::nullopt;
  }
  // Anchor: the submap scan nearest to the matched pose.
  double best_d = 1e300;
  for (const auto& [d, k] : near) {
    const double dk = std::hypot(poses[k].x - match.pose.x, poses[k].y - match.pose.y);
    if (dk < best_d) {
      best_d = dk;
      match.anchor = k;
    }
  }
  match.relative = match.pose.relative_to(poses[match.anchor]);
  const double travel = path_length - keys[match.anchor].path_length;
  const Pose2 correction = match.pose.relative_to(estimate);
  if (std::hypot(correction.x, correction.y) >
          config.drift_floor_xy + config.drift_rate_xy * travel ||
      std::abs(rad_to_deg(correction.theta)) >
          config.drift_floor_theta_deg + config.drift_rate_theta_deg * travel) {
    return std::nullopt;
  }
  return match;
}

}  // namespace esfleet
