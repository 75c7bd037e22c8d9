#pragma once
// What `esfleet-leader --map PATH` serves: a saved map, loaded without running the SLAM, from a
// leader's checkpoint or a ROS map_server YAML file (docs/faults.md, "Serving a saved map").
//
// PATH is taken as
//  - a leader's checkpoint when it is a directory: the leader's --out directory OUT (holding
//    OUT/checkpoint/manifest.json) or that checkpoint directory itself (holding manifest.json);
//    the counters come back exactly (load_checkpoint), with the map id, epoch, scans and
//    parameters the manifest records;
//  - a ROS map_server YAML file otherwise (load_ros_map), its cells turned into counters by
//    grid_from_occupancy (core/include/esfleet/core/occupancy_import.hpp).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "checkpoint.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/occupancy_import.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet::leader {

enum class ServedMapKind { kCheckpoint, kRosYaml };
/// "checkpoint" or "ros_yaml" (stats.json "kind").
const char* to_string(ServedMapKind kind);

struct ServedMap {
  ServedMapKind kind = ServedMapKind::kCheckpoint;
  std::string path;  ///< PATH as given
  /// The file read first: OUT/checkpoint/manifest.json or the YAML file.
  std::string file;
  /// The directories the map's files live in (the leader must not write its outputs there):
  /// OUT and OUT/checkpoint, or the YAML file's directory.
  std::vector<std::string> dirs;
  GridMap map;
  /// Checkpoint: map id, epoch, scans, input and parameters from its manifest.
  std::optional<CheckpointInfo> checkpoint;
  /// YAML: where the pixels landed (a shift when the origin is not a whole number of cells) and
  /// the origin yaw, which is not applied.
  std::optional<OccupancyPlacement> placement;
  double origin_theta = 0.0;
};

/// Loads PATH (see the file comment). A checkpoint is loaded into a Slam of `slam`'s
/// configuration with the checkpoint's own map layout (the cell_size and tile_edge its manifest
/// records) and loop closure off (nothing is mapped); a YAML map gets `slam.map` with
/// cell_size = the YAML resolution. Throws std::runtime_error naming the file (and the line or
/// field where the reader gives one): a PATH that does not exist, a directory without a
/// checkpoint, a corrupt checkpoint, a malformed YAML or image.
ServedMap load_served_map(const std::string& path, SlamConfig slam);

/// Cells of a map in the classes ROS reads (ros_cell_value, default thresholds) over the
/// bounding box of its known cells, as the map.pgm the leader writes shows them: occupied, free,
/// and unknown (the rest of the box: never observed, or in between the thresholds).
struct CellClasses {
  std::uint64_t occupied = 0;
  std::uint64_t free = 0;
  std::uint64_t unknown = 0;
};
CellClasses cell_classes(const GridMap& map);

}  // namespace esfleet::leader
