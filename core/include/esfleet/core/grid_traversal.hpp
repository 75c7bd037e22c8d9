#pragma once
// The cells a straight segment crosses on the grid: the map update's err counting and the
// contribution check's look for occupied cells along a beam share it.

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>

#include "esfleet/core/grid_map.hpp"

namespace esfleet {

/// The stepping of traverse() (Amanatides & Woo 1987), for a visitor that carries state from a
/// cell to its neighbour (GridMap::ErrPath): from the cell containing (x0, y0), calls visit()
/// for every cell the segment to (x1, y1) (cell units) crosses before the one containing the
/// end point, in order, and after each visit move(mx, my) to the next cell (one of mx, my is 0,
/// the other +-1; the last move enters the end point's cell). The step count is fixed by the
/// cell distance, so rounding can never make it overshoot or loop.
template <typename Visit, typename Move>
void traverse_steps(double x0, double y0, double x1, double y1, Visit&& visit, Move&& move) {
  const auto cx = static_cast<std::int32_t>(std::floor(x0));
  const auto cy = static_cast<std::int32_t>(std::floor(y0));
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
    visit();
    if (left_y == 0 || (left_x > 0 && t_max_x < t_max_y)) {
      t_max_x += t_delta_x;
      --left_x;
      move(step_x, 0);
    } else {
      t_max_y += t_delta_y;
      --left_y;
      move(0, step_y);
    }
  }
}

/// Visits every cell the segment from (x0, y0) to (x1, y1) (cell units) crosses, in order,
/// calling `visit` for each cell before the one containing the end point (traverse_steps).
template <typename Visit>
void traverse(double x0, double y0, double x1, double y1, Visit&& visit) {
  CellIndex cell{static_cast<std::int32_t>(std::floor(x0)),
                 static_cast<std::int32_t>(std::floor(y0))};
  traverse_steps(
      x0, y0, x1, y1, [&] { visit(cell); },
      [&](std::int32_t mx, std::int32_t my) {
        cell.x += mx;
        cell.y += my;
      });
}

}  // namespace esfleet
