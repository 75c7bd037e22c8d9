#pragma once
// The simulated 2D laser: exact ray casting in the world grid plus a simple sensor model.
//
// Ray casting is the Amanatides-Woo grid traversal (A Fast Voxel Traversal Algorithm, 1987):
// from the sensor position the ray visits every cell it crosses, in order, stepping to whichever
// cell boundary (vertical or horizontal) comes first. The range of a beam is the distance from
// the sensor to the point where the ray ENTERS the first occupied cell (its boundary crossing),
// so a wall's face is measured, not its centre. Unknown and free cells let the ray pass; a ray
// that meets no occupied cell within max_range (or leaves the image heading away from it) is a
// no-return and reports exactly max_range (LaserScan::is_no_return).
//
// Sensor model, per beam: with probability `dropout` a no-return; otherwise the exact range plus
// Gaussian noise N(0, range_noise^2), clamped at 0; a noisy reading at or beyond max_range is a
// no-return. The laser sits at the robot's pose (no mounting offset) and takes the whole scan
// at one instant (no motion distortion).

#include <vector>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/sim/world.hpp"

namespace esfleet::sim {

struct LaserConfig {
  int beams = 181;            ///< beams per scan, >= 2
  double fov_deg = 180.0;     ///< field of view, centred forward; (0, 360]
  double max_range = 30.0;    ///< metres; no-return readings report this; (0, 81.9)
  double range_noise = 0.01;  ///< sigma of the Gaussian range noise, metres, >= 0
  double dropout = 0.005;     ///< probability per beam of a no-return, [0, 1]

  /// Throws std::invalid_argument naming the field (as its flag, e.g. "--beams").
  void validate() const;
  /// Angle of beam 0 in the sensor frame: -fov/2.
  double angle_min() const;
  /// Angle between consecutive beams: fov / (beams - 1) (the first and last beams lie on the
  /// edges of the field of view). For a full 360 degree fov: 360 / beams, so no direction twice.
  double angle_increment() const;
};

/// Distance from (x, y) along direction `angle` (rad, world frame) to the boundary of the first
/// occupied cell, or `max_range` if there is none closer. A start inside an occupied cell gives 0.
double cast_ray(const World& world, double x, double y, double angle, double max_range);

/// One scan from `pose` with the sensor model, stamped `stamp` (no odometry set).
/// Random draws come from `rng` (per beam: one uniform, then one normal if the beam hits).
LaserScan simulate_scan(const World& world, const LaserConfig& config, const Pose2& pose,
                        double stamp, Rng& rng);

}  // namespace esfleet::sim
