#pragma once
// Path planning for the simulated robots: A* on a coarse grid over the world's drivable space.
//
// The coarse grid groups f x f world cells (f = round(cell / world resolution), at least 1),
// aligned with the world image. A coarse cell is open when EVERY world cell in it is free with
// clearance >= the planning clearance, so any point of an open cell is drivable. Moves go to the
// 8 neighbours; a diagonal move needs both cells it squeezes between open (no corner cutting),
// so the straight segment between two neighbouring open centres stays in open cells.
// Connected components use the same moves.
//
// A* (octile heuristic, admissible and consistent) finds a shortest 8-connected path; the path
// is then shortened by string pulling: from each kept waypoint, jump to the farthest later
// waypoint whose straight segment crosses only open cells (exact grid traversal, and a segment
// passing exactly through a cell corner needs all cells at that corner open).

#include <cstdint>
#include <optional>
#include <vector>

#include "esfleet/core/random.hpp"
#include "esfleet/sim/world.hpp"

namespace esfleet::sim {

/// A point in the world frame (metres).
struct Point2 {
  double x = 0.0;
  double y = 0.0;
};

class PlanGrid {
 public:
  /// Builds the coarse grid of `world` with cells of about `cell` metres, open where every
  /// world cell has clearance >= `clearance`. Throws std::invalid_argument for cell <= 0.
  PlanGrid(const World& world, double cell, double clearance);

  int width() const { return width_; }
  int height() const { return height_; }
  double cell_size() const { return cell_; }
  bool open(Cell c) const { return inside(c) && open_[index(c)] != 0; }
  Cell cell_at(const Point2& p) const;
  Point2 centre_of(Cell c) const;
  std::size_t open_count() const { return open_count_; }

  /// Connected component id of every cell (-1 for closed cells), ids 0.. in decreasing size.
  const std::vector<int>& components() const { return component_; }
  int component_of(Cell c) const { return open(c) ? component_[index(c)] : -1; }
  /// Open cells of component `id`.
  const std::vector<Cell>& component_cells(int id) const { return component_cells_[id]; }
  int component_count() const { return static_cast<int>(component_cells_.size()); }

  /// Shortest 8-connected path from cell `from` to cell `to` (both open), as cell centres after
  /// string pulling, ending at the centre of `to` and not including `from`'s centre. nullopt if
  /// there is no path.
  std::optional<std::vector<Point2>> plan(Cell from, Cell to) const;
  /// True if the segment a-b crosses only open cells.
  bool line_of_sight(const Point2& a, const Point2& b) const;

 private:
  bool inside(Cell c) const { return c.x >= 0 && c.y >= 0 && c.x < width_ && c.y < height_; }
  std::size_t index(Cell c) const {
    return static_cast<std::size_t>(c.y) * static_cast<std::size_t>(width_) +
           static_cast<std::size_t>(c.x);
  }
  /// Move from `c` by (dx, dy) allowed (target open, no corner cutting)?
  bool can_move(Cell c, int dx, int dy) const;
  void label_components();
  std::vector<Point2> shorten(const std::vector<Cell>& cells) const;

  double origin_x_ = 0.0, origin_y_ = 0.0, cell_ = 0.0;
  int width_ = 0, height_ = 0;
  std::vector<std::uint8_t> open_;
  std::size_t open_count_ = 0;
  std::vector<int> component_;
  std::vector<std::vector<Cell>> component_cells_;
};

}  // namespace esfleet::sim
