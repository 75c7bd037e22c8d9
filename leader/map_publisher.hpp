#pragma once
// The leader's side of map sharing: publishes the tiles changed since the last call, the map
// summary and the leader's pose, and keeps the byte counts that show what tiles save over
// republishing the whole map (the ROS `map` topic habit).
//
// A changed tile goes out either whole (MapTile, on the transient-local topic late joiners
// read) or as a delta (MapTileDelta: the counter differences against the version sent last).
// Whole when the tile is new, or when `full_every` - 1 deltas of the tile followed its last whole
// copy, or that copy is `full_period` seconds of scan time old; otherwise as a delta. (Counted in
// publishes of the tile, not in tile versions: a version is bumped per scan, several per publish.)
// When the map is complete, and whenever a new tile reader matched since the last publish,
// every tile whose whole copy is not its newest version goes out whole, so late joiners (which
// never see the deltas before they joined) catch up with the current map at once.

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/dds/map_convert.hpp"
#include "esfleet/dds/writer.hpp"

namespace esfleet::leader {

struct PublishStats {
  std::uint64_t publishes = 0;       ///< calls to publish()
  std::uint64_t tiles = 0;           ///< tile samples written
  std::uint64_t tile_bytes = 0;      ///< their CDR bytes
  std::uint64_t deltas = 0;          ///< tile delta samples written
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

/// When a changed tile goes out whole rather than as a delta (see the file comment).
struct DeltaPolicy {
  /// One whole tile every this many publishes of a tile (full_every - 1 deltas in between);
  /// 1 = always whole (no deltas).
  std::uint64_t full_every = 60;
  /// Whole tile when the whole copy is this many seconds of scan time old.
  double full_period = 60.0;
};

class MapPublisher {
 public:
  MapPublisher(dds::Node& node, dds::MapIdentity id, std::string robot_id,
               TileEncoding encoding = TileEncoding::kMedZlib, DeltaPolicy policy = {});

  /// Publishes every tile changed since the last call (takes the map's dirty set), whole or as
  /// a delta, then the summary, then the pose. `pose.stamp` is the scan time for full_period.
  /// With `complete`, also every tile whose whole copy is older than its newest version.
  void publish(GridMap& map, const TimedPose& pose, float fitness, bool complete,
               std::uint32_t scans, const std::string& params_json);
  /// Forgets what was sent and marks every tile dirty, so the next publish() sends every tile
  /// whole.
  void republish_all(GridMap& map) {
    sent_.clear();
    map.mark_all_dirty();
  }

  const PublishStats& stats() const { return stats_; }
  dds::TileWriter& tile_writer() { return tiles_; }
  /// Waits (bounded) until every matched reader acknowledged everything written.
  bool flush(std::chrono::milliseconds timeout);

 private:
  /// What the followers were sent of one tile.
  struct Sent {
    std::uint64_t version = 0;       ///< version of the last tile or delta written
    std::vector<std::uint32_t> hit;  ///< the counters at `version`
    std::vector<std::uint32_t> err;
    std::uint64_t full_version = 0;       ///< version of the last whole tile written
    std::uint64_t deltas_since_full = 0;  ///< deltas written since that whole tile
    double full_stamp = 0.0;              ///< scan time of that write
  };
  /// Writes tile `k` whole (true) or as a delta; updates `sent`.
  void send(const GridMap& map, TileKey k, Sent& sent, bool whole, double stamp, std::int64_t now);

  dds::MapIdentity id_;
  std::string robot_id_;
  TileEncoding encoding_;
  DeltaPolicy policy_;
  std::map<TileKey, Sent> sent_;
  int tile_readers_ = 0;  ///< tile readers matched at the last publish
  dds::TileWriter tiles_;
  dds::TileDeltaWriter deltas_;
  dds::MetaWriter meta_;
  dds::PoseWriter pose_;
  PublishStats stats_;
};

}  // namespace esfleet::leader
