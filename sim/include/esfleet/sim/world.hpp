#pragma once
// The simulated world: a static occupancy image (ROS map_server format) split into what the
// laser sees and where robots may drive.
//
// Cell classes (from OccupancyImage::cells, 0..100 occupancy percent or -1 unknown):
//   occupied  value >= kOccupiedPercent (65, map_server's default occupied_thresh): stops rays;
//   free      value == 0 (known free): the only cells a robot may stand on;
//   unknown   everything else (-1, and 1..64 in scale mode): rays pass through it (the unknown
//             part of a SLAM map lies mostly outside the walls), robots never enter it.
//
// Clearance: the distance from a cell to the nearest cell that is not free (occupied or unknown:
// a robot keeps away from both, since unknown space may hide obstacles), from an exact Euclidean
// distance transform between cell centres (cv::distanceTransform, DIST_MASK_PRECISE) over the
// image padded with one non-free pixel. It is stored as a lower bound for every point of the
// cell: centre distance minus sqrt(2) cells (the farthest a point of this cell and a point of
// the other cell can be from their centres). So a position whose cell has clearance c is at
// least c metres from every non-free cell, whatever its place inside the cell.
// Drivable = free with clearance >= WorldConfig::clearance.

#include <cstdint>
#include <string>
#include <vector>

#include "esfleet/core/ros_map_reader.hpp"

namespace esfleet::sim {

/// Occupancy percent from which a cell stops rays (map_server's default occupied_thresh).
inline constexpr int kOccupiedPercent = 65;

/// Integer cell coordinates in the world image (column, row from the bottom).
struct Cell {
  int x = 0;
  int y = 0;
  friend bool operator==(const Cell&, const Cell&) = default;
};

class World {
 public:
  /// Builds the cell classes and the clearance field. Throws std::invalid_argument for an
  /// empty image, a non-zero origin yaw (not supported), or cells of the wrong size.
  explicit World(OccupancyImage image);

  double resolution() const { return image_.resolution; }
  double origin_x() const { return image_.origin_x; }
  double origin_y() const { return image_.origin_y; }
  int width() const { return image_.width; }
  int height() const { return image_.height; }
  const OccupancyImage& image() const { return image_; }

  bool inside(Cell c) const { return c.x >= 0 && c.y >= 0 && c.x < width() && c.y < height(); }
  /// Cell containing the world point (x, y) (may lie outside the image).
  Cell cell_at(double x, double y) const;
  /// World position of the centre of `c`.
  void centre_of(Cell c, double& x, double& y) const;

  bool occupied(Cell c) const { return inside(c) && flags_[index(c)] == kOccupied; }
  bool free(Cell c) const { return inside(c) && flags_[index(c)] == kFree; }
  /// Lower bound (m) of the distance from any point of `c` to any non-free cell; <= 0 for
  /// non-free cells and cells outside the image.
  double clearance(Cell c) const { return inside(c) ? clearance_[index(c)] : -1.0; }
  /// A point is drivable when its cell is free with clearance >= `min_clearance`.
  bool drivable(double x, double y, double min_clearance) const {
    const Cell c = cell_at(x, y);
    return free(c) && clearance(c) >= min_clearance;
  }

 private:
  enum Flag : std::uint8_t { kUnknown = 0, kFree = 1, kOccupied = 2 };
  std::size_t index(Cell c) const {
    return static_cast<std::size_t>(c.y) * static_cast<std::size_t>(width()) +
           static_cast<std::size_t>(c.x);
  }

  OccupancyImage image_;
  std::vector<std::uint8_t> flags_;  ///< Flag per cell, same layout as image_.cells
  std::vector<float> clearance_;     ///< metres, same layout
};

/// Loads `yaml_path` with load_ros_map and builds the World. Throws std::runtime_error naming
/// the file for anything load_ros_map refuses or World rejects.
World load_world(const std::string& yaml_path);

}  // namespace esfleet::sim
