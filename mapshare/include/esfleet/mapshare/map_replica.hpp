#pragma once
// The follower's half of map sharing: a copy of the leader's map whose counters equal the
// leader's, built from the messages the leader's TileSender makes. Every message is validated
// first; a rejected or stale one never changes the map. No network here: follower/ feeds it the
// messages that arrived over DDS (follower/map_subscriber.hpp), a test feeds it a TileSender's
// output directly.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/mapshare/messages.hpp"

namespace esfleet::mapshare {

/// What the replica did with a message.
enum class Applied {
  kApplied,    ///< the replica changed
  kStale,      ///< version not newer than what the replica holds (a duplicate or reordering)
  kIgnored,    ///< another map id or an older epoch
  kRejected,   ///< malformed: see the error string
  kNeedsBase,  ///< a delta whose base version the replica does not hold (the next whole tile
               ///< brings the tile up to date)
};

/// Not thread-safe: feed it from one thread (DDS callbacks hand samples over through a queue).
class MapReplica {
 public:
  /// `map_id` empty = follow the first map seen. `local` gives the replica's own settings
  /// (max_tile_coord bounds accepted keys, pyramid_levels for localisation); cell size and
  /// tile edge come from the leader.
  explicit MapReplica(std::string map_id = {}, GridMapConfig local = {});

  /// Validates and applies one tile, whole or a delta. On kRejected, `error` (if given) says
  /// why, naming the field.
  ///  - Whole: tiles received before the first summary create the map from their own layout; a
  ///    newer epoch restarts it. Rejected: another protocol, a cell size or tile edge out of
  ///    range or (same epoch) other than the map's, cells != tile_edge^2, a key outside
  ///    +-max_tile_coord, version 0 (versions start at 1), a payload longer than any tile of
  ///    this size can need (max_payload_bytes), or one that does not decode. Nothing is decoded
  ///    or allocated for a stale version.
  ///  - Delta: the same checks plus base_version < version. Applied only when the replica holds
  ///    the tile at exactly base_version: the differences are added (modulo 2^32) and the tile
  ///    takes `version`. kStale when the replica's version is >= version; kNeedsBase when it
  ///    lacks the base (no such tile, another version, another epoch or no map yet).
  Applied apply(const TileMessage& tile, std::string* error = nullptr);
  /// Records the leader's summary (layout, bounds, completeness). Rejected: another protocol, a
  /// layout out of range or (same epoch) other than the map's, and bounds that no map can have:
  /// min > max, a bound outside +-max_tile_coord, or more tiles than the bounds hold. kStale: an
  /// older summary (lower map_version) of the same epoch arriving late.
  Applied apply(const MetaMessage& meta, std::string* error = nullptr);

  bool has_map() const { return map_.has_value(); }
  const GridMap& map() const { return *map_; }  ///< requires has_map()
  const std::string& map_id() const { return map_id_; }
  std::uint32_t epoch() const { return epoch_; }
  const std::optional<MetaMessage>& meta() const { return meta_; }
  /// The leader said its map is final and the replica holds all of it, at the same versions.
  bool complete() const;
  /// The leader said its map is final and the replica holds fewer tiles than it announced
  /// (a late joiner while the map arrives): a pose found now would be found in part of it.
  bool arriving() const;

 private:
  Applied apply_whole(const TileMessage& t, std::string* error);
  Applied apply_delta(const TileMessage& d, std::string* error);
  /// The checks every message starts with: protocol version (kRejected), another map id or an
  /// older epoch (kIgnored); std::nullopt when the message may go on.
  std::optional<Applied> screen(std::uint16_t protocol, const std::string& map_id,
                                std::uint32_t epoch, std::string* error) const;
  /// Checks the layout, cells and key of a tile and its payload size; returns an error or "".
  std::string check_tile(const TileMessage& t, bool against_map) const;
  /// Checks layout fields shared by tiles and summaries (ranges, and equality with the current
  /// map when `against_map`); returns an error or "".
  std::string check_layout(float cell_size, std::uint32_t tile_edge, bool against_map) const;
  /// The local config with the sender's cell size and tile edge (what reset() makes a map of).
  GridMapConfig layout_config(float cell_size, std::uint32_t tile_edge) const;
  /// Starts (or restarts, on a newer epoch) the map with this layout.
  void reset(std::uint32_t epoch, float cell_size, int tile_edge);

  std::string map_id_;
  GridMapConfig local_;
  std::uint32_t epoch_ = 0;
  std::optional<GridMap> map_;
  std::optional<MetaMessage> meta_;
  std::vector<std::uint32_t> hit_, err_;  ///< decode buffers
};

/// What a follower received and what became of it, per kind of message.
struct ReceiveStats {
  std::uint64_t tiles_received = 0;
  std::uint64_t tiles_applied = 0;
  std::uint64_t tiles_stale = 0;     ///< version not newer than held (duplicates, stale senders)
  std::uint64_t tiles_ignored = 0;   ///< other map id / older epoch
  std::uint64_t tiles_rejected = 0;  ///< malformed or oversized
  std::uint64_t deltas_received = 0;
  std::uint64_t deltas_applied = 0;
  std::uint64_t deltas_stale = 0;
  std::uint64_t deltas_needs_base = 0;  ///< base missing: the next whole tile brings the tile up
  std::uint64_t deltas_ignored = 0;     ///< other map id / older epoch
  std::uint64_t deltas_rejected = 0;
  std::uint64_t meta_received = 0;
  std::uint64_t meta_rejected = 0;

  /// Counts one tile (whole or delta, per `delta`) and its outcome.
  void count_tile(bool delta, Applied outcome);
  /// Counts one summary and its outcome.
  void count_meta(Applied outcome);
  std::uint64_t applied() const { return tiles_applied + deltas_applied; }
};

}  // namespace esfleet::mapshare
