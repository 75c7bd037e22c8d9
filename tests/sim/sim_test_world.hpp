#pragma once
// Synthetic worlds for the simulator tests: rooms drawn cell by cell into an OccupancyImage.

#include <cmath>
#include <cstdint>

#include "esfleet/core/ros_map_reader.hpp"
#include "esfleet/sim/world.hpp"

namespace esfleet::sim::testing {

/// A w x h cell image, all `value` (0 free, 100 occupied, -1 unknown), at `res` m per cell,
/// origin (ox, oy).
inline OccupancyImage blank_image(int w, int h, std::int8_t value, double res = 0.05,
                                  double ox = 0.0, double oy = 0.0) {
  OccupancyImage img;
  img.resolution = res;
  img.origin_x = ox;
  img.origin_y = oy;
  img.width = w;
  img.height = h;
  img.cells.assign(static_cast<std::size_t>(w) * h, value);
  return img;
}

/// Sets the cells x0 <= x < x1, y0 <= y < y1 (clipped) to `value`.
inline void fill(OccupancyImage& img, int x0, int y0, int x1, int y1, std::int8_t value) {
  for (int y = std::max(0, y0); y < std::min(img.height, y1); ++y) {
    for (int x = std::max(0, x0); x < std::min(img.width, x1); ++x) {
      img.cells[static_cast<std::size_t>(y) * img.width + x] = value;
    }
  }
}

/// A free square room of n x n cells with a one-cell occupied wall around it.
inline OccupancyImage square_room(int n, double res = 0.05) {
  OccupancyImage img = blank_image(n, n, 100, res);
  fill(img, 1, 1, n - 1, n - 1, 0);
  return img;
}

/// Two rooms (8 m x 6 m at 5 cm) split by a wall at x = 4 m with a 1.2 m door, a pillar in
/// the right room, an unknown patch in the left one and unknown space outside the walls.
inline OccupancyImage two_rooms() {
  OccupancyImage img = blank_image(180, 140, -1);  // 9 m x 7 m, unknown around
  fill(img, 10, 10, 170, 130, 100);                // outer wall ...
  fill(img, 11, 11, 169, 129, 0);                  // ... around free space
  fill(img, 89, 11, 91, 129, 100);                 // inner wall at x ~ 4.5 m
  fill(img, 89, 58, 91, 82, 0);                    // door, 1.2 m
  fill(img, 120, 40, 135, 60, 100);                // pillar
  fill(img, 30, 90, 45, 100, -1);                  // unknown patch
  return img;
}

/// Exact distance (m) from (x, y) to the nearest cell of `world` that is not free (cells as
/// squares; outside the image counts as not free). Brute force, for checking the clearance.
inline double distance_to_non_free(const World& world, double x, double y) {
  const double res = world.resolution();
  // Outside the image: the distance to the image border.
  double best = std::min({x - world.origin_x(), y - world.origin_y(),
                          world.origin_x() + world.width() * res - x,
                          world.origin_y() + world.height() * res - y});
  for (int cy = 0; cy < world.height(); ++cy) {
    for (int cx = 0; cx < world.width(); ++cx) {
      if (world.free({cx, cy})) continue;
      const double x0 = world.origin_x() + cx * res, y0 = world.origin_y() + cy * res;
      const double dx = std::max({x0 - x, 0.0, x - (x0 + res)});
      const double dy = std::max({y0 - y, 0.0, y - (y0 + res)});
      best = std::min(best, std::hypot(dx, dy));
    }
  }
  return best;
}

}  // namespace esfleet::sim::testing
