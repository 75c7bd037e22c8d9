#include "esfleet/core/map_update.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "esfleet/core/grid_traversal.hpp"

namespace esfleet {

namespace {
/// Throws std::invalid_argument naming update.<name> unless `value` is finite and >= 0.
void require_non_negative(double value, const char* name) {
  if (!(value >= 0.0) || !std::isfinite(value)) {
    throw std::invalid_argument(std::string("update.") + name + " must be >= 0, got " +
                                std::to_string(value));
  }
}
}  // namespace

void MapUpdateConfig::validate() const {
  if (!(alpha_res > 0.0) || !std::isfinite(alpha_res)) {
    throw std::invalid_argument("update.alpha_res must be > 0, got " + std::to_string(alpha_res));
  }
  if (!(write_range > 0.0) || !(write_range <= kMaxBeamRange)) {
    throw std::invalid_argument("update.write_range must be in (0, " +
                                std::to_string(static_cast<int>(kMaxBeamRange)) + "] m, got " +
                                std::to_string(write_range));
  }
  require_non_negative(no_return_clear_range, "no_return_clear_range");
  if (no_return_clear_range > write_range) {
    throw std::invalid_argument(
        "update.no_return_clear_range must be at most update.write_range (" +
        std::to_string(write_range) + " m), got " + std::to_string(no_return_clear_range));
  }
  require_non_negative(free_margin, "free_margin");
  require_non_negative(beam_fill_deg, "beam_fill");
  require_non_negative(beam_fill_max_gap, "beam_fill_max_gap");
  require_non_negative(beam_fill_min_step, "beam_fill_min_step");
  require_non_negative(beam_fill_min_turn_deg, "beam_fill_min_turn");
}

MapPoints map_points(const LaserScan& scan, float min_range, float max_range,
                     const MapUpdateConfig& config) {
  const BeamFill fill{config.beam_fill_deg, config.beam_fill_max_gap};
  MapPoints out;
  if (beam_fill_points(scan, fill) == 0) return out;
  out.filled = true;
  out.points = prepare_scan(scan, min_range, max_range, fill);
  return out;
}

namespace {

/// Counts into the map (or out of it, kRemove), one cell at a time; chosen at compile time, as
/// it runs for every cell a beam crosses.
template <bool kRemove>
struct Counter {
  GridMap& map;
  MapUpdateStats& stats;
  void err(CellIndex c) {
    if (kRemove ? map.remove_err_deferred(c) : map.add_err_deferred(c)) {
      ++stats.errs;
    } else {
      ++stats.out_of_range;
    }
  }
  /// err() for every cell traverse() visits from (x0, y0) to (x1, y1), carrying the tile from
  /// a cell to its neighbour (GridMap::ErrPath).
  void errs_along(double x0, double y0, double x1, double y1) {
    GridMap::ErrPath<!kRemove> path(map, {static_cast<std::int32_t>(std::floor(x0)),
                                          static_cast<std::int32_t>(std::floor(y0))});
    std::size_t written = 0, visited = 0;
    traverse_steps(
        x0, y0, x1, y1,
        [&] {
          written += path.write();
          ++visited;
        },
        [&](std::int32_t mx, std::int32_t my) { path.move(mx, my); });
    stats.errs += written;
    stats.out_of_range += visited - written;
  }
  void hit(CellIndex c) {
    if (kRemove ? map.remove_hit_deferred(c) : map.add_hit_deferred(c)) {
      ++stats.hits;
    } else {
      ++stats.out_of_range;
    }
  }
};

template <bool kRemove>
MapUpdateStats update_cells(GridMap& map, const ScanPoints& points, const Pose2& pose,
                            const MapUpdateConfig& config) {
  MapUpdateStats stats;
  Counter<kRemove> counter{map, stats};
  const double inv = 1.0 / map.cell_size();
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double sx = pose.x * inv, sy = pose.y * inv;
  if (beyond_any_map(sx, sy) || !std::isfinite(pose.theta)) return stats;  // nothing to write
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double ex = sx + (c * points.x[i] - s * points.y[i]) * inv;
    const double ey = sy + (s * points.x[i] + c * points.y[i]) * inv;
    const double range = points.range[i];
    if (range > config.write_range) {
      // Beyond the map-writing range: no end point, the beam clears up to the range.
      const double f = config.write_range / range;
      counter.errs_along(sx, sy, sx + f * (ex - sx), sy + f * (ey - sy));
      continue;
    }
    const CellIndex end{static_cast<std::int32_t>(std::floor(ex)),
                        static_cast<std::int32_t>(std::floor(ey))};
    // The err counting ends at `stop` (the beam shortened by the margin); its cell is counted
    // too unless it is the end point's.
    if (range > config.free_margin) {
      const double f = config.free_margin > 0.0 ? (range - config.free_margin) / range : 1.0;
      const double stop_x = f < 1.0 ? sx + f * (ex - sx) : ex;
      const double stop_y = f < 1.0 ? sy + f * (ey - sy) : ey;
      const CellIndex stop{static_cast<std::int32_t>(std::floor(stop_x)),
                           static_cast<std::int32_t>(std::floor(stop_y))};
      if (config.exact_traversal) {
        counter.errs_along(sx, sy, stop_x, stop_y);
        if (stop != end) counter.err(stop);
      } else {
        // The paper's sampling: L = ceil(alpha_res * d) points along the beam, the last one the
        // end point; consecutive samples in the same cell count once.
        const auto samples = static_cast<int>(std::ceil(config.alpha_res * range));
        CellIndex last{std::numeric_limits<std::int32_t>::min(), 0};
        for (int j = 0; j < samples; ++j) {
          const double g = static_cast<double>(j) / samples;
          if (g > f) break;
          const CellIndex cell{static_cast<std::int32_t>(std::floor(sx + g * (ex - sx))),
                               static_cast<std::int32_t>(std::floor(sy + g * (ey - sy)))};
          if (cell == end || cell == last) continue;
          counter.err(cell);
          last = cell;
        }
      }
    }
    counter.hit(end);
  }
  if (config.no_return_clear_range > 0.0) {
    const double r = config.no_return_clear_range * inv;
    for (const float a : points.no_return_angles) {
      const double ex = sx + r * std::cos(pose.theta + a);
      const double ey = sy + r * std::sin(pose.theta + a);
      counter.errs_along(sx, sy, ex, ey);
    }
  }
  return stats;
}

}  // namespace

MapUpdateStats update_map(GridMap& map, const ScanPoints& points, const Pose2& pose,
                          const MapUpdateConfig& config, bool remove, bool commit) {
  const MapUpdateStats stats = remove ? update_cells<true>(map, points, pose, config)
                                      : update_cells<false>(map, points, pose, config);
  if (commit) map.commit_update();
  return stats;
}

}  // namespace esfleet
