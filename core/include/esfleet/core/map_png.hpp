#pragma once
// A colour PNG of a GridMap with a trajectory drawn over it (for people, not for map_server,
// though map_server reads it as the PGM when no trajectory is drawn).

#include <string>
#include <vector>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/ros_map_format.hpp"

namespace esfleet {

/// Writes a colour PNG of the map to `path` (atomically), same crop and pixel layout as
/// save_ros_map: observed cells in their PGM grey level, cells never observed light blue-grey
/// (RGB u-15, u, u+15 for the unknown level u = kUnknownLevel, so RGB 190,205,220: the channel
/// mean is u and map_server still reads them as unknown). The trajectory is drawn over it as a
/// 1-pixel red (255,0,0) polyline through the pixels containing the poses, segments clipped to
/// the image and non-finite poses skipped; then a green (0,255,0) filled disc of radius 3 px at
/// the first pose and a blue (0,0,255) one at the last (discs only when the pose lies inside
/// the image). Throws as save_ros_map does (std::runtime_error naming the path on failure).
void save_map_png(const GridMap& map, const std::vector<TimedPose>& trajectory,
                  const std::string& path, const OccupancyThresholds& th = {});

}  // namespace esfleet
