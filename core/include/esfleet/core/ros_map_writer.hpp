#pragma once
// Saving a GridMap as a ROS map_server map (ros_map_format.hpp): the PGM image and its YAML.

#include <string>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/ros_map_format.hpp"

namespace esfleet {

/// Writes <dir>/<name>.pgm (binary P5, maxval 255) and <dir>/<name>.yaml in ROS map_server
/// format (mode trinary, negate 0, origin [x, y, 0.0], occupied_thresh kRosOccupiedThresh,
/// free_thresh kRosFreeThresh), creating `dir` if missing. Each file is written atomically
/// (write_file_atomically), the PGM first; the pair as a whole is not.
///
/// Each cell is written in the level of its class, ros_cell_value(hit, err, th): occupied
/// kOccupiedLevel (0, black), free kFreeLevel (254, white), unknown kUnknownLevel (205, also
/// for cells never observed). So map_server reads the file back as exactly ros_cell_value of
/// every cell: what the leader publishes on /map.
///
/// An empty map writes a 1x1 unknown image at origin (0, 0). `name` must be non-empty and use
/// only [A-Za-z0-9._-] (it is written unquoted into the YAML). Throws std::invalid_argument
/// for a bad name or thresholds (OccupancyThresholds::validate), std::runtime_error naming the
/// path on an I/O failure or when the image would exceed kMaxMapImagePixels (load_ros_map
/// would refuse it).
void save_ros_map(const GridMap& map, const std::string& dir, const std::string& name = "map",
                  const OccupancyThresholds& th = {});

}  // namespace esfleet
