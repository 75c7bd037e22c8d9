#pragma once
// Wheel odometry as real robots have it, made from a clean path: each step's motion (the pose
// change between two scans, in the robot's frame) gets Gaussian errors whose size grows with
// the distance driven and the angle turned, and the noisy steps are chained, so the error
// drifts as wheel odometry does. Seeded and deterministic (core Rng, no std distributions).
//
// Per step of distance d (m) and turn a (rad) in the robot frame, when the robot moved
// (d or |a| above 1e-9; a robot standing still reports no motion, as encoders do):
//   dx, dy += N(0, sigma_t^2),   sigma_t = distance_frac * d + distance_base_m
//   dtheta += N(0, sigma_r^2),   sigma_r = turn_frac * |a| + deg(turn_base_deg)
//                                          + deg(turn_per_m_deg) * d
// The defaults are the example of cheap wheel odometry: 5 % of distance + 0.5 cm,
// 5 % of turn + 0.5 deg + 1 deg per metre.

#include <cstdint>
#include <vector>

#include "esfleet/core/geometry.hpp"

namespace esfleet {

struct OdometryNoise {
  double distance_frac = 0.05;     ///< translation sigma per metre driven
  double distance_base_m = 0.005;  ///< translation sigma per moving step, metres
  double turn_frac = 0.05;         ///< heading sigma per radian turned
  double turn_base_deg = 0.5;      ///< heading sigma per moving step, degrees
  double turn_per_m_deg = 1.0;     ///< heading sigma per metre driven, degrees
  /// Throws std::invalid_argument naming the field when one is negative or not finite.
  void validate() const;
};

/// The noisy odometry of `path` (one pose per scan, e.g. a log's odometry or corrected poses):
/// starts at path[0] and chains each step's motion with the errors above. Same size as `path`.
std::vector<Pose2> noisy_odometry(const std::vector<Pose2>& path, const OdometryNoise& noise,
                                  std::uint64_t seed);

}  // namespace esfleet
