#pragma once
// One 2D laser scan as it comes from a log, a driver or the DDS scan topic.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "esfleet/core/geometry.hpp"

namespace esfleet {

struct LaserScan {
  double stamp = 0.0;            ///< seconds; for CARMEN logs the ipc timestamp
  float angle_min = 0.0f;        ///< angle of beam 0, radians, in the sensor frame (x forward)
  float angle_increment = 0.0f;  ///< radians between consecutive beams
  float max_range = 81.9f;       ///< readings at or above this are no-return readings
  std::vector<float> ranges;     ///< metres; NaN/inf/negative are rejected by the reader
  /// Odometry pose reported with the scan, when the source has one. Used only when odometry
  /// use is switched on. (In GMapping-corrected logs this field holds corrected poses: such
  /// logs must be run laser-only.)
  std::optional<Pose2> odometry;

  float angle(std::size_t i) const { return angle_min + static_cast<float>(i) * angle_increment; }
  bool is_no_return(std::size_t i) const { return ranges[i] >= max_range; }
};

}  // namespace esfleet
