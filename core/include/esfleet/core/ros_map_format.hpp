#pragma once
// The ROS map_server map format as esfleet writes and reads it (a PGM or PNG image plus a YAML
// file): what the writer (ros_map_writer.hpp), the colour PNG (map_png.hpp) and the reader
// (ros_map_reader.hpp) agree on.
//
// ROS map_server / nav2_map_server read a grey level x (0..255, negate 0) as the occupancy
// p = 1 - x / 255: occupied if p > occupied_thresh, free if p < free_thresh, else unknown
// (mode trinary). save_ros_map picks, for each cell, a grey level that reads back in the class
// the counters give it, so a saved map loads in map_server with the same free / occupied /
// unknown cells (see save_ros_map for the exact levels).
//
// Image layout (PGM and PNG alike): the crop is exactly GridMap::known_bounds(), no margin,
// one pixel per cell; pixel column c is cell x = min.x + c and pixel row r (row 0 = the top of
// the file) is cell y = max.y - r, so north (+y) is up. The YAML origin is the world position
// of the lower-left corner of the bottom-left pixel: (min.x * cell_size, min.y * cell_size).

#include <cstdint>

namespace esfleet {

/// Largest image (width * height) that load_ros_map reads and save_ros_map / save_map_png write.
inline constexpr std::uint64_t kMaxMapImagePixels = 100'000'000;

/// Occupancy thresholds on p = hit / (hit + err), written to the YAML as map_server's
/// occupied_thresh / free_thresh. Need 0 < free < occupied < 1.
struct OccupancyThresholds {
  double occupied = 0.65;  ///< p >= occupied is an occupied cell (ROS occupied_thresh)
  double free = 0.196;     ///< p <= free is a free cell (ROS free_thresh)
};

/// The ROS occupancy value of a cell with counters (hit, err): what map_server reads back from
/// the cell's grey level in the saved map (mode trinary) and what the leader publishes on /map.
/// -1 unknown (hit + err == 0, or p strictly between the thresholds), 0 free (p <= th.free),
/// 100 occupied (p >= th.occupied), p = hit / (hit + err).
std::int8_t ros_cell_value(std::uint64_t hit, std::uint64_t err, const OccupancyThresholds& th = {});

}  // namespace esfleet
