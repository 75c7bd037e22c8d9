#pragma once
// The ROS map_server map format as esfleet writes and reads it (a PGM or PNG image plus a YAML
// file): what the writer (ros_map_writer.hpp), the colour PNG (map_png.hpp) and the reader
// (ros_map_reader.hpp) agree on.
//
// ROS map_server / nav2_map_server read a grey level x (0..255, negate 0) as the occupancy
// o = 1 - x / 255: occupied if o > occupied_thresh, free if o < free_thresh, else unknown
// (mode trinary). esfleet writes the ROS-standard YAML thresholds (kRosOccupiedThresh,
// kRosFreeThresh) and only three levels: black for the cells ros_cell_value calls occupied,
// white for free ones, grey 205 for unknown ones. So map_server reads map.pgm back as exactly
// ros_cell_value of every cell, the values the leader publishes on /map: one mapping for both.
//
// Image layout (PGM and PNG alike): the crop is exactly GridMap::known_bounds(), no margin,
// one pixel per cell; pixel column c is cell x = min.x + c and pixel row r (row 0 = the top of
// the file) is cell y = max.y - r, so north (+y) is up. The YAML origin is the world position
// of the lower-left corner of the bottom-left pixel: (min.x * cell_size, min.y * cell_size).

#include <cstdint>

namespace esfleet {

/// Largest image (width * height) that load_ros_map reads and save_ros_map / save_map_png write.
inline constexpr std::uint64_t kMaxMapImagePixels = 100'000'000;

/// The thresholds the YAML gives map_server (ROS defaults; tools assume them). They apply to
/// the grey levels, not to the counters: see OccupancyThresholds for how a cell is classified.
inline constexpr double kRosOccupiedThresh = 0.65;
inline constexpr double kRosFreeThresh = 0.196;

/// Grey levels of the three classes in map.pgm (negate 0); under the thresholds above they read
/// back as occupancy 1.0 (occupied), 0.004 (free) and 0.19608 (unknown, just above
/// free_thresh: what ROS map_saver writes for unknown).
inline constexpr std::uint8_t kOccupiedLevel = 0;
inline constexpr std::uint8_t kFreeLevel = 254;
inline constexpr std::uint8_t kUnknownLevel = 205;

/// How a cell's counters classify it (ros_cell_value). The counters: hit = beams that ended in
/// the cell, err = beams that passed through it; p = hit / (hit + err), the map value the SLAM's
/// fitness scores an end point with (fitness.hpp).
///
/// The defaults make occupied what the SLAM treats as a wall. The fitness counts an end point
/// on a cell with hit > 0 as on a wall, however low p is; a wall cell that beams graze (the
/// wall's surface crosses the cell, the beams pass through its free part) has p well below
/// 0.5. So a cell is occupied when it has stopped beams more than once (min_hits: one stray
/// return, a person or a glitch, is not a wall) and is not free by ROS's own free threshold
/// (p > 0.196: more than about one in five of the beams that reach it end in it). Free: p at
/// most 0.196. With the defaults every cell that stopped two or more beams is occupied or
/// free; unknown are the cells never observed and those that stopped one beam only and are
/// not free. (docs/slam.md, "Map files", has the measurements.)
struct OccupancyThresholds {
  double occupied = 0.196;     ///< occupied needs p > occupied, in [0, 1)
  std::uint64_t min_hits = 2;  ///< ... and hit >= min_hits, >= 1
  double free = 0.196;         ///< not occupied and p <= free: free; in [0, occupied]

  /// Throws std::invalid_argument naming the field when a value is out of its range (or NaN).
  void validate() const;
};

/// The ROS occupancy value of a cell with counters (hit, err) under `th`: 100 occupied
/// (hit >= th.min_hits and p > th.occupied), else 0 free (p <= th.free), else -1 unknown; -1
/// also when hit + err == 0. What map_server reads back from the cell's level in the saved map
/// (mode trinary) and what the leader publishes on /map. Does not validate `th`.
std::int8_t ros_cell_value(std::uint64_t hit, std::uint64_t err,
                           const OccupancyThresholds& th = {});

}  // namespace esfleet
