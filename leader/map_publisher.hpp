#pragma once
// The leader's side of map sharing: publishes the tiles changed since the last call, the map
// summary and the leader's pose, and keeps the byte counts that show what tiles save over
// republishing the whole map (the ROS `map` topic habit).

#include <cstdint>
#include <string>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/dds/map_convert.hpp"
#include "esfleet/dds/writer.hpp"

namespace esfleet::leader {

struct PublishStats {
  std::uint64_t publishes = 0;       ///< calls to publish()
  std::uint64_t tiles = 0;           ///< tile samples written
  std::uint64_t tile_bytes = 0;      ///< their CDR bytes
  std::uint64_t meta_bytes = 0;      ///< summary CDR bytes
  std::uint64_t pose_bytes = 0;      ///< pose CDR bytes
  std::uint64_t write_failures = 0;  ///< samples DDS refused
  /// What a nav_msgs/OccupancyGrid of the known bounds at every publish would have cost:
  /// one byte per cell plus about 100 bytes of header and metadata.
  std::uint64_t full_map_bytes = 0;
};

class MapPublisher {
 public:
  MapPublisher(dds::Node& node, dds::MapIdentity id, std::string robot_id,
               TileEncoding encoding = TileEncoding::kMedZlib);

  /// Publishes every tile changed since the last call (takes the map's dirty set), then the
  /// summary, then the pose.
  void publish(GridMap& map, const TimedPose& pose, float fitness, bool complete,
               std::uint32_t scans, const std::string& params_json);
  /// Marks every tile dirty so the next publish() sends the whole map.
  void republish_all(GridMap& map) { map.mark_all_dirty(); }

  const PublishStats& stats() const { return stats_; }
  dds::TileWriter& tile_writer() { return tiles_; }
  /// Waits (bounded) until every matched reader acknowledged everything written.
  bool flush(std::chrono::milliseconds timeout);

 private:
  dds::MapIdentity id_;
  std::string robot_id_;
  TileEncoding encoding_;
  dds::TileWriter tiles_;
  dds::MetaWriter meta_;
  dds::PoseWriter pose_;
  PublishStats stats_;
};

}  // namespace esfleet::leader
