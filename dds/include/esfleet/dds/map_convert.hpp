#pragma once
// Conversion between core map types and the map messages, and the follower's side of map
// sharing: validating received tiles and keeping a map replica whose counters equal the
// leader's. No Fast DDS entities here (only the generated message classes), so this is tested
// without a network.

#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include <esfleet/msg/esfleet.h>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/tile_codec.hpp"

namespace esfleet::dds {

/// Which map a message belongs to: the leader names its map and bumps the epoch when it starts
/// a new one (restart without resume).
struct MapIdentity {
  std::string map_id = "map";
  std::uint32_t epoch = 1;
};

/// Largest tile payload any valid tile can need, for the largest tile (kMaxTileCells): kRaw takes
/// 8 bytes per cell, the zlib encodings inflate to at most 2 * kMaxVarintBytes per cell and
/// deflate adds less than 0.04 % to that (zlib's deflateBound). Followers drop bigger samples
/// before queueing them; MapReplica applies the same bound for the message's tile size.
inline constexpr std::size_t kMaxTilePayloadBytes =
    2 * kMaxVarintBytes * kMaxTileCells + (std::size_t{1} << 16);

/// Nanoseconds of CLOCK_REALTIME (the clock the latency figures use on both sides).
std::int64_t realtime_ns();

/// Sum of the versions of all tiles: grows whenever any tile changes, equal on leader and
/// follower once the follower holds every tile at its newest version.
std::uint64_t map_version(const GridMap& map);

/// Leader: the message for tile `key` of `map` (which must exist).
msg::MapTile tile_to_msg(const GridMap& map, TileKey key, const MapIdentity& id,
                         TileEncoding encoding, std::int64_t stamp_ns);

/// Leader: the delta of tile `key` of `map` (which must exist) against the counters `base_hit`,
/// `base_err` the leader sent as version `base_version` (< the tile's version): the per-cell
/// differences now - base (uint32, modulo 2^32), encoded with `encoding`. Throws
/// std::invalid_argument for a missing tile, base spans of the wrong size or a base version not
/// older than the tile's.
msg::MapTileDelta tile_delta_to_msg(const GridMap& map, TileKey key, std::uint64_t base_version,
                                    std::span<const std::uint32_t> base_hit,
                                    std::span<const std::uint32_t> base_err, const MapIdentity& id,
                                    TileEncoding encoding, std::int64_t stamp_ns);

/// Leader: the map summary.
msg::MapMeta meta_to_msg(const GridMap& map, const MapIdentity& id, bool complete,
                         std::uint32_t scans, const std::string& params_json,
                         std::int64_t stamp_ns);

msg::RobotPose pose_to_msg(const std::string& robot_id, const TimedPose& pose, float fitness,
                           std::uint8_t status);

msg::LaserScanMsg scan_to_msg(const std::string& robot_id, std::uint32_t seq,
                              const LaserScan& scan);
/// Throws std::invalid_argument naming the field for a scan that cannot be used (no beams,
/// more than 10000, non-finite angles).
LaserScan scan_from_msg(const msg::LaserScanMsg& m);

/// Simulator: the true pose of robot `robot_id` (kTruthTopic; stamp = the scan's stamp).
msg::TruthPose truth_to_msg(const std::string& robot_id, const TimedPose& pose);
/// Evaluation: the true pose in a truth message (the robot is m.robot_id()). Throws
/// std::invalid_argument naming the field for another protocol version, an empty robot_id or a
/// non-finite stamp, x, y or theta.
TimedPose truth_from_msg(const msg::TruthPose& m);

/// What a follower did with a received tile or summary.
enum class Applied {
  kApplied,    ///< the replica changed
  kStale,      ///< version not newer than what the replica holds (a duplicate or reordering)
  kIgnored,    ///< another map id or an older epoch
  kRejected,   ///< malformed: see the error string
  kNeedsBase,  ///< a delta whose base version the replica does not hold (the next full tile fixes
               ///< it)
};

/// The follower's copy of the leader's map. Not thread-safe: feed it from one thread (DDS
/// callbacks hand samples over through a queue).
class MapReplica {
 public:
  /// `map_id` empty = follow the first map seen. `local` gives the replica's own settings
  /// (max_tile_coord bounds accepted keys, pyramid_levels for localisation); cell size and
  /// tile edge come from the leader.
  explicit MapReplica(std::string map_id = {}, GridMapConfig local = {});

  /// Validates and applies one tile. On kRejected, `error` (if given) says why, naming the
  /// field. Tiles received before the first summary create the map from their own layout.
  /// Rejected: another protocol, a cell size or tile edge out of range or (same epoch) other
  /// than the map's, cells != tile_edge^2, a key outside +-max_tile_coord, version 0 (the
  /// leader numbers a tile's versions from 1), a payload longer than any tile of this size can
  /// need, or one that does not decode. Nothing is decoded or allocated for a stale version.
  Applied apply(const msg::MapTile& tile, std::string* error = nullptr);
  /// Validates and applies one tile delta (same checks as a tile, plus base_version < version).
  /// Applied only when the replica holds the tile at exactly base_version: then the differences
  /// are added (modulo 2^32) and the tile takes `version`. kStale when the replica's version is
  /// >= version; kNeedsBase when it lacks the base (no such tile, another version, another
  /// epoch or no map yet): nothing changes, the next full tile brings the tile up to date.
  Applied apply(const msg::MapTileDelta& delta, std::string* error = nullptr);
  /// Records the leader's summary (layout, bounds, completeness). Rejected: another protocol, a
  /// layout out of range or (same epoch) other than the map's, and bounds that no map can have:
  /// min > max, a bound outside +-max_tile_coord, or more tiles than the bounds hold.
  Applied apply(const msg::MapMeta& meta, std::string* error = nullptr);

  bool has_map() const { return map_.has_value(); }
  const GridMap& map() const { return *map_; }  ///< requires has_map()
  const std::string& map_id() const { return map_id_; }
  std::uint32_t epoch() const { return epoch_; }
  const std::optional<msg::MapMeta>& meta() const { return meta_; }
  /// The leader said its map is final and the replica holds all of it, at the same versions.
  bool complete() const;

 private:
  /// The checks every message starts with: protocol version (kRejected), another map id or an
  /// older epoch (kIgnored); nothing when the message may go on.
  template <class Msg>
  std::optional<Applied> screen(const Msg& m, std::string* error) const;
  /// Starts (or restarts, on a newer epoch) the map with this layout.
  void reset(std::uint32_t epoch, float cell_size, int tile_edge);
  /// Checks layout fields shared by tiles and summaries (ranges, and equality with the current
  /// map when `against_map`); returns an error or "".
  std::string check_layout(float cell_size, std::uint32_t tile_edge, bool against_map) const;
  /// Checks cells == tile_edge^2 and the key range; returns an error or "".
  std::string check_tile(std::uint32_t cells, std::uint32_t tile_edge, TileKey key) const;

  std::string map_id_;
  GridMapConfig local_;
  std::uint32_t epoch_ = 0;
  std::optional<GridMap> map_;
  std::optional<msg::MapMeta> meta_;
  std::vector<std::uint32_t> hit_, err_;  ///< decode buffers
};

}  // namespace esfleet::dds
