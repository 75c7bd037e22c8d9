#include "esfleet/core/map_update.hpp"

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace esfleet {

void MapUpdateConfig::validate() const {
  if (!(alpha_res > 0.0) || !std::isfinite(alpha_res)) {
    throw std::invalid_argument("update.alpha_res must be > 0, got " + std::to_string(alpha_res));
  }
  if (!(no_return_clear_range >= 0.0) || !std::isfinite(no_return_clear_range)) {
    throw std::invalid_argument("update.no_return_clear_range must be >= 0, got " +
                                std::to_string(no_return_clear_range));
  }
}

namespace {

struct Counter {
  GridMap& map;
  MapUpdateStats& stats;
  bool remove;
  void err(CellIndex c) {
    if (remove ? map.remove_err(c) : map.add_err(c)) {
      ++stats.errs;
    } else {
      ++stats.out_of_range;
    }
  }
  void hit(CellIndex c) {
    if (remove ? map.remove_hit(c) : map.add_hit(c)) {
      ++stats.hits;
    } else {
      ++stats.out_of_range;
    }
  }
};

/// Visits every cell the segment from (x0, y0) to (x1, y1) (cell units) crosses, in order,
/// calling `visit` for each cell before the one containing the end point. Exact traversal
/// (Amanatides & Woo 1987); the step count is fixed by the cell distance, so rounding can never
/// make it overshoot or loop.
template <typename Visit>
void traverse(double x0, double y0, double x1, double y1, Visit&& visit) {
  auto cx = static_cast<std::int32_t>(std::floor(x0));
  auto cy = static_cast<std::int32_t>(std::floor(y0));
  const auto ex = static_cast<std::int32_t>(std::floor(x1));
  const auto ey = static_cast<std::int32_t>(std::floor(y1));
  const double dx = x1 - x0, dy = y1 - y0;
  const std::int32_t step_x = dx > 0 ? 1 : -1;
  const std::int32_t step_y = dy > 0 ? 1 : -1;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double t_delta_x = dx != 0.0 ? std::abs(1.0 / dx) : kInf;
  const double t_delta_y = dy != 0.0 ? std::abs(1.0 / dy) : kInf;
  double t_max_x = dx != 0.0 ? ((dx > 0 ? (cx + 1) - x0 : x0 - cx) * t_delta_x) : kInf;
  double t_max_y = dy != 0.0 ? ((dy > 0 ? (cy + 1) - y0 : y0 - cy) * t_delta_y) : kInf;
  std::int32_t left_x = std::abs(ex - cx);
  std::int32_t left_y = std::abs(ey - cy);
  while (left_x + left_y > 0) {
    visit(CellIndex{cx, cy});
    const bool step_in_x = left_y == 0 || (left_x > 0 && t_max_x < t_max_y);
    if (step_in_x) {
      cx += step_x;
      t_max_x += t_delta_x;
      --left_x;
    } else {
      cy += step_y;
      t_max_y += t_delta_y;
      --left_y;
    }
  }
}

}  // namespace

MapUpdateStats update_map(GridMap& map, const ScanPoints& points, const Pose2& pose,
                          const MapUpdateConfig& config, bool remove, bool commit) {
  MapUpdateStats stats;
  Counter counter{map, stats, remove};
  const double inv = 1.0 / map.cell_size();
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double sx = pose.x * inv, sy = pose.y * inv;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double ex = sx + (c * points.x[i] - s * points.y[i]) * inv;
    const double ey = sy + (s * points.x[i] + c * points.y[i]) * inv;
    const CellIndex end{static_cast<std::int32_t>(std::floor(ex)),
                        static_cast<std::int32_t>(std::floor(ey))};
    if (config.exact_traversal) {
      traverse(sx, sy, ex, ey, [&](CellIndex cell) { counter.err(cell); });
    } else {
      // The paper's sampling: L = ceil(alpha_res * d) points along the beam, the last one the
      // end point; consecutive samples in the same cell count once.
      const auto samples = static_cast<int>(std::ceil(config.alpha_res * points.range[i]));
      CellIndex last{std::numeric_limits<std::int32_t>::min(), 0};
      for (int j = 0; j < samples; ++j) {
        const double f = static_cast<double>(j) / samples;
        const CellIndex cell{static_cast<std::int32_t>(std::floor(sx + f * (ex - sx))),
                             static_cast<std::int32_t>(std::floor(sy + f * (ey - sy)))};
        if (cell == end || cell == last) continue;
        counter.err(cell);
        last = cell;
      }
    }
    counter.hit(end);
  }
  if (config.no_return_clear_range > 0.0) {
    const double r = config.no_return_clear_range * inv;
    for (const float a : points.no_return_angles) {
      const double ex = sx + r * std::cos(pose.theta + a);
      const double ey = sy + r * std::sin(pose.theta + a);
      traverse(sx, sy, ex, ey, [&](CellIndex cell) { counter.err(cell); });
    }
  }
  if (commit) map.commit_update();
  return stats;
}

}  // namespace esfleet
