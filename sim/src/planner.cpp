#include "esfleet/sim/planner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <queue>
#include <stdexcept>

namespace esfleet::sim {
namespace {

constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
constexpr int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};

double octile(Cell a, Cell b) {
  const int dx = std::abs(a.x - b.x), dy = std::abs(a.y - b.y);
  return std::max(dx, dy) + (std::numbers::sqrt2 - 1.0) * std::min(dx, dy);
}

}  // namespace

PlanGrid::PlanGrid(const World& world, double cell, double clearance) {
  if (!(cell > 0.0)) throw std::invalid_argument("plan cell size must be > 0");
  const int f = std::max(1, static_cast<int>(std::lround(cell / world.resolution())));
  cell_ = f * world.resolution();
  origin_x_ = world.origin_x();
  origin_y_ = world.origin_y();
  width_ = world.width() / f;  // a partial coarse cell at the edge stays out
  height_ = world.height() / f;
  open_.assign(static_cast<std::size_t>(width_) * std::max(height_, 0), 0);
  for (int cy = 0; cy < height_; ++cy) {
    for (int cx = 0; cx < width_; ++cx) {
      bool ok = true;
      for (int y = cy * f; ok && y < (cy + 1) * f; ++y) {
        for (int x = cx * f; ok && x < (cx + 1) * f; ++x) {
          ok = world.free({x, y}) && world.clearance({x, y}) >= clearance;
        }
      }
      if (ok) {
        open_[index({cx, cy})] = 1;
        ++open_count_;
      }
    }
  }
  label_components();
}

Cell PlanGrid::cell_at(const Point2& p) const {
  return {static_cast<int>(std::floor((p.x - origin_x_) / cell_)),
          static_cast<int>(std::floor((p.y - origin_y_) / cell_))};
}

Point2 PlanGrid::centre_of(Cell c) const {
  return {origin_x_ + (c.x + 0.5) * cell_, origin_y_ + (c.y + 0.5) * cell_};
}

bool PlanGrid::can_move(Cell c, int dx, int dy) const {
  if (!open({c.x + dx, c.y + dy})) return false;
  return dx == 0 || dy == 0 || (open({c.x + dx, c.y}) && open({c.x, c.y + dy}));
}

void PlanGrid::label_components() {
  component_.assign(open_.size(), -1);
  std::vector<std::vector<Cell>> comps;
  std::vector<Cell> stack;
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      if (!open({x, y}) || component_[index({x, y})] >= 0) continue;
      const int id = static_cast<int>(comps.size());
      comps.emplace_back();
      component_[index({x, y})] = id;
      stack.push_back({x, y});
      while (!stack.empty()) {
        const Cell c = stack.back();
        stack.pop_back();
        comps[id].push_back(c);
        for (int k = 0; k < 8; ++k) {
          const Cell n{c.x + kDx[k], c.y + kDy[k]};
          if (can_move(c, kDx[k], kDy[k]) && component_[index(n)] < 0) {
            component_[index(n)] = id;
            stack.push_back(n);
          }
        }
      }
    }
  }
  // Renumber by decreasing size (ties: first found), so component 0 is the largest.
  std::vector<int> order(comps.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return comps[a].size() > comps[b].size(); });
  std::vector<int> new_id(comps.size());
  component_cells_.clear();
  for (std::size_t i = 0; i < order.size(); ++i) {
    new_id[order[i]] = static_cast<int>(i);
    component_cells_.push_back(std::move(comps[order[i]]));
  }
  for (int& id : component_) {
    if (id >= 0) id = new_id[id];
  }
}

std::optional<std::vector<Point2>> PlanGrid::plan(Cell from, Cell to) const {
  if (!open(from) || !open(to) || component_of(from) != component_of(to)) return std::nullopt;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::vector<double> g(open_.size(), kInf);
  std::vector<int> parent(open_.size(), -1);
  using Entry = std::pair<double, int>;  // f = g + h, cell index
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  const int start = static_cast<int>(index(from)), goal = static_cast<int>(index(to));
  g[start] = 0.0;
  queue.push({octile(from, to), start});
  while (!queue.empty()) {
    const auto [f, i] = queue.top();
    queue.pop();
    if (i == goal) break;
    const Cell c{i % width_, i / width_};
    if (f > g[i] + octile(c, to) + 1e-9) continue;  // an outdated entry
    for (int k = 0; k < 8; ++k) {
      if (!can_move(c, kDx[k], kDy[k])) continue;
      const Cell n{c.x + kDx[k], c.y + kDy[k]};
      const int j = static_cast<int>(index(n));
      const double step = (kDx[k] != 0 && kDy[k] != 0) ? std::numbers::sqrt2 : 1.0;
      if (g[i] + step < g[j]) {
        g[j] = g[i] + step;
        parent[j] = i;
        queue.push({g[j] + octile(n, to), j});
      }
    }
  }
  if (g[goal] == kInf) return std::nullopt;
  std::vector<Cell> cells;
  for (int i = goal; i != -1; i = parent[i]) cells.push_back({i % width_, i / width_});
  std::reverse(cells.begin(), cells.end());
  return shorten(cells);
}

std::vector<Point2> PlanGrid::shorten(const std::vector<Cell>& cells) const {
  std::vector<Point2> out;
  std::size_t i = 0;
  while (i + 1 < cells.size()) {
    std::size_t j = i + 1;
    // Farthest later cell in sight. Paths are short enough for the quadratic worst case.
    for (std::size_t k = cells.size() - 1; k > i + 1; --k) {
      if (line_of_sight(centre_of(cells[i]), centre_of(cells[k]))) {
        j = k;
        break;
      }
    }
    out.push_back(centre_of(cells[j]));
    i = j;
  }
  return out;
}

bool PlanGrid::line_of_sight(const Point2& a, const Point2& b) const {
  // Amanatides-Woo traversal in coarse cells, as in cast_ray.
  const double u0 = (a.x - origin_x_) / cell_, v0 = (a.y - origin_y_) / cell_;
  const double u1 = (b.x - origin_x_) / cell_, v1 = (b.y - origin_y_) / cell_;
  Cell c{static_cast<int>(std::floor(u0)), static_cast<int>(std::floor(v0))};
  const Cell end{static_cast<int>(std::floor(u1)), static_cast<int>(std::floor(v1))};
  if (!open(c)) return false;
  const double du = u1 - u0, dv = v1 - v0;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const int sx = du > 0 ? 1 : -1, sy = dv > 0 ? 1 : -1;
  // Parameters t in [0, 1] along the segment.
  const double delta_x = du != 0.0 ? 1.0 / std::abs(du) : kInf;
  const double delta_y = dv != 0.0 ? 1.0 / std::abs(dv) : kInf;
  double next_x = du != 0.0 ? (du > 0 ? (c.x + 1 - u0) : (u0 - c.x)) * delta_x : kInf;
  double next_y = dv != 0.0 ? (dv > 0 ? (c.y + 1 - v0) : (v0 - c.y)) * delta_y : kInf;
  const std::size_t max_steps =
      static_cast<std::size_t>(std::abs(end.x - c.x) + std::abs(end.y - c.y));
  for (std::size_t s = 0; s < max_steps && !(c == end); ++s) {
    if (std::abs(next_x - next_y) < 1e-12) {
      // Exactly through a corner: the segment touches all cells there.
      if (!open({c.x + sx, c.y}) || !open({c.x, c.y + sy})) return false;
      c.x += sx;
      c.y += sy;
      next_x += delta_x;
      next_y += delta_y;
      ++s;
    } else if (next_x < next_y) {
      c.x += sx;
      next_x += delta_x;
    } else {
      c.y += sy;
      next_y += delta_y;
    }
    if (!open(c)) return false;
  }
  return true;
}

}  // namespace esfleet::sim
