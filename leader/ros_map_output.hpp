#pragma once
// The leader's map for ROS 2 tools: nav_msgs/OccupancyGrid on /map (reliable, transient-local,
// depth 1, as map_server and slam_toolbox) every --ros-map-period seconds of scan time, and
// between two of them map_msgs/OccupancyGridUpdate on /map_updates with the tiles changed since
// the last publish (RViz2's Map display applies them). Cell values are ros_cell_value: what
// the saved map.pgm reads back as in map_server.
//
// Only tiles whose ROS values changed go out (most counter changes leave every cell's class as
// it was): one update per row of tiles (first to last changed tile of the row), or one update
// of the rectangle around them all when the rows are many. /map covers the bounding box of the
// map's tiles; when a change falls outside the box of the last /map (the map grew by a tile), the
// whole /map goes out at once instead of an update (RViz2 drops updates outside the last map); so
// it does when a new /map reader matched (a late joiner's transient-local copy may be old).

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/ros_map_format.hpp"
#include "esfleet/dds/ros.hpp"
#include "esfleet/dds/ros_msg.hpp"

namespace esfleet::leader {

struct RosMapStats {
  std::uint64_t maps = 0;       ///< /map messages
  std::uint64_t map_bytes = 0;  ///< their CDR bytes
  std::uint64_t updates = 0;    ///< /map_updates messages
  std::uint64_t update_bytes = 0;
  std::uint64_t grown = 0;               ///< whole maps sent early because the map grew
  std::uint64_t for_joiners = 0;         ///< whole maps sent early because a /map reader matched
  std::uint64_t changed_tile_cells = 0;  ///< cells of the tiles whose ROS values changed
  /// What a whole /map at every publish would have cost (the same message size each time).
  std::uint64_t whole_every_publish_bytes = 0;
  double cpu_s = 0.0;  ///< thread CPU spent building and writing them
  nlohmann::json json() const;
};

class RosMapOutput {
 public:
  /// Creates the /map and /map_updates writers on `node` (which must outlive this object).
  RosMapOutput(dds::Node& node, std::string frame, double map_period_s,
               OccupancyThresholds thresholds = {});

  /// At scan time `stamp`: /map if due (the first call, --ros-map-period passed, the map grew
  /// out of the last /map, or `whole`), and an update of the tiles changed since the last call
  /// that the sent /map does not already hold.
  void publish(const GridMap& map, double stamp, bool whole);

  const RosMapStats& stats() const { return stats_; }

 private:
  void send_map(const GridMap& map, double stamp);
  void send_update(const GridMap& map, const dds::RosGridWindow& rect, double stamp);
  /// The tiles whose ROS values changed since the last call (new tiles included).
  std::vector<TileKey> changed_tiles(const GridMap& map);

  struct SentTile {
    std::uint64_t version = 0;
    std::vector<std::int8_t> values;  ///< the ROS values last sent
  };

  std::string frame_;
  double period_s_;
  OccupancyThresholds thresholds_;
  std::map<TileKey, SentTile> sent_;
  dds::RosGridWindow window_;  ///< of the last /map
  double last_map_stamp_ = -1e300;
  bool sent_any_ = false;
  int readers_ = 0;  ///< /map readers matched at the last publish
  RosMapStats stats_;
  dds::RosMapWriter map_;
  dds::RosMapUpdateWriter updates_;
};

}  // namespace esfleet::leader
