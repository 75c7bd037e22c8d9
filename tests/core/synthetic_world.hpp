#pragma once
// A small synthetic world for core tests: line-segment walls and an exact ray caster, so a
// test knows the true pose of every scan it makes.

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/map_update.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet::testing {

struct Segment {
  double x0, y0, x1, y1;
};

/// An asymmetric 12 m x 8 m room with a pillar and an inner wall, so every pose is unique.
inline std::vector<Segment> asymmetric_room() {
  return {
      {0, 0, 12, 0},     {12, 0, 12, 8}, {12, 8, 0, 8},    {0, 8, 0, 0},    // outer walls
      {4, 0, 4, 3},                                                         // inner wall
      {7, 5, 8, 5},      {8, 5, 8, 6.5}, {8, 6.5, 7, 6.5}, {7, 6.5, 7, 5},  // pillar
      {9.5, 1.5, 11, 3},                                                    // slanted wall
      {1.5, 6, 3, 6},                                                       // shelf
  };
}

/// Range along the ray from (x, y) with direction angle a to the nearest wall, or +inf.
inline double cast_ray(const std::vector<Segment>& world, double x, double y, double a) {
  const double dx = std::cos(a), dy = std::sin(a);
  double best = std::numeric_limits<double>::infinity();
  for (const Segment& s : world) {
    const double ex = s.x1 - s.x0, ey = s.y1 - s.y0;
    const double den = dx * ey - dy * ex;
    if (std::abs(den) < 1e-12) continue;
    const double t = ((s.x0 - x) * ey - (s.y0 - y) * ex) / den;
    const double u = ((s.x0 - x) * dy - (s.y0 - y) * dx) / den;
    if (t > 1e-9 && u >= 0.0 && u <= 1.0) best = std::min(best, t);
  }
  return best;
}

/// A 181-beam, 180-degree scan (1 degree steps) taken from `pose`.
inline LaserScan make_scan(const std::vector<Segment>& world, const Pose2& pose, double stamp = 0,
                           int beams = 181, double max_range = 30.0) {
  LaserScan scan;
  scan.stamp = stamp;
  scan.angle_min = static_cast<float>(-std::numbers::pi / 2);
  scan.angle_increment = static_cast<float>(std::numbers::pi / (beams - 1));
  scan.max_range = 81.9f;
  for (int i = 0; i < beams; ++i) {
    const double r = cast_ray(world, pose.x, pose.y, pose.theta + scan.angle(i));
    scan.ranges.push_back(r < max_range ? static_cast<float>(r) : 81.91f);
  }
  return scan;
}

/// The map a leader would have of a `w` x `h` m world: scans from a grid of poses over its
/// free space (pyramid levels for the localiser's coarse search).
inline GridMap map_of(const std::vector<Segment>& world, double w, double h) {
  GridMapConfig c;
  c.pyramid_levels = 3;
  GridMap map(c);
  for (double x = 0.5; x < w; x += 0.75) {
    for (double y = 0.5; y < h; y += 0.75) {
      for (int k = 0; k < 4; ++k) {
        const Pose2 p{x, y, k * std::numbers::pi / 2};
        update_map(map, prepare_scan(make_scan(world, p)), p, MapUpdateConfig{});
      }
    }
  }
  return map;
}

}  // namespace esfleet::testing
