#pragma once
// Saving a GridMap as a ROS map_server map (ros_map_format.hpp): the PGM image and its YAML.

#include <string>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/ros_map_format.hpp"

namespace esfleet {

/// Writes <dir>/<name>.pgm (binary P5, maxval 255) and <dir>/<name>.yaml in ROS map_server
/// format (mode trinary, negate 0, origin [x, y, 0.0], the thresholds of `th`), creating `dir`
/// if missing. Each file is written atomically (write_file_atomically), the PGM first; the pair
/// as a whole is not.
///
/// Grey levels, with the default thresholds in brackets:
///  - unknown cell (hit + err == 0): the level closest to 205 that map_server reads as unknown
///    [205];
///  - p >= th.occupied: 0 (black);
///  - p <= th.free: 254 (white), or 255 if the free threshold is below 1/255;
///  - in between: round(255 * (1 - p)), clamped into the levels map_server reads as unknown
///    [90, 205] and kept off the unknown level when another level is left [so 205 -> 204].
/// Levels are chosen with a 1e-9 margin on the thresholds, so the classes survive the small
/// rounding differences between map_server implementations.
///
/// An empty map writes a 1x1 unknown image at origin (0, 0). `name` must be non-empty and use
/// only [A-Za-z0-9._-] (it is written unquoted into the YAML). Throws std::invalid_argument
/// for a bad name or thresholds (not 0 < free < occupied < 1, or no grey level between them),
/// std::runtime_error naming the path on an I/O failure or when the image would exceed
/// kMaxMapImagePixels (load_ros_map would refuse it).
void save_ros_map(const GridMap& map, const std::string& dir, const std::string& name = "map",
                  const OccupancyThresholds& th = {});

}  // namespace esfleet
