#pragma once
// The leader's map-sharing transport: each publish() runs the protocol's sending step
// (mapshare::TileSender: which tiles go out, whole or as deltas) and writes its messages in
// order on the tile, delta and summary topics, then the leader's pose. It keeps the byte counts
// that show what tiles save over republishing the whole map (the ROS `map` topic habit).

#include <chrono>
#include <cstdint>
#include <string>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/dds/writer.hpp"
#include "esfleet/mapshare/tile_sender.hpp"

namespace esfleet::leader {

struct PublishStats {
  std::uint64_t publishes = 0;       ///< calls to publish()
  std::uint64_t tiles = 0;           ///< tiles written (every part of each)
  std::uint64_t tile_bytes = 0;      ///< CDR bytes of their parts
  std::uint64_t deltas = 0;          ///< tile deltas written (every part of each)
  std::uint64_t delta_bytes = 0;     ///< their CDR bytes
  std::uint64_t meta_bytes = 0;      ///< summary CDR bytes
  std::uint64_t pose_bytes = 0;      ///< pose CDR bytes
  std::uint64_t write_failures = 0;  ///< samples DDS refused
  /// Publishes that brought every whole tile up to date because a tile reader had joined.
  std::uint64_t joiner_refreshes = 0;
  /// What a nav_msgs/OccupancyGrid of the known bounds at every publish would have cost:
  /// one byte per cell plus about 100 bytes of header and metadata.
  std::uint64_t full_map_bytes = 0;
};

class MapPublisher {
 public:
  /// Creates the tile, delta, summary and pose writers on `node` (which must outlive this
  /// object); the pose writer in the robot's partition (docs/security.md). Throws
  /// std::runtime_error naming the topic if DDS refuses.
  MapPublisher(dds::Node& node, mapshare::MapIdentity id, std::string robot_id,
               TileEncoding encoding = TileEncoding::kMedZlib, mapshare::DeltaPolicy policy = {});

  /// Publishes every tile changed since the last call (see mapshare::TileSender), then the
  /// summary, then the pose. `pose.stamp` is the scan time for the delta policy's full_period.
  void publish(GridMap& map, const TimedPose& pose, float fitness, bool complete,
               std::uint32_t scans, const std::string& params_json);
  /// The same without a pose (a map server has no robot): the changed tiles, then the summary.
  /// `stamp` takes the place of the scan time.
  void publish_map(GridMap& map, double stamp, bool complete, std::uint32_t scans,
                   const std::string& params_json);
  /// The next publish() sends every tile whole (mapshare::TileSender::republish_all).
  void republish_all(GridMap& map) { sender_.republish_all(map); }

  const PublishStats& stats() const { return stats_; }
  /// Waits (bounded) until every matched reader acknowledged everything written.
  bool flush(std::chrono::milliseconds timeout);

 private:
  /// Copies the writers' byte and failure counts into stats_.
  void count_bytes();

  std::string robot_id_;
  mapshare::TileSender sender_;
  int tile_readers_ = 0;  ///< tile readers matched at the last publish
  dds::TileWriter tiles_;
  dds::TileDeltaWriter deltas_;
  dds::MetaWriter meta_;
  dds::PoseWriter pose_;
  PublishStats stats_;
};

}  // namespace esfleet::leader
