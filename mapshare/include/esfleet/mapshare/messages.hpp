#pragma once
// The map-sharing protocol's messages in plain C++ (no DDS): what the leader's TileSender makes
// of its map and what a follower's MapReplica applies. dds/ carries them as the wire types of
// idl/esfleet.idl, field for field (dds/include/esfleet/dds/to_msg.hpp, from_msg.hpp); the field
// comments there are the wire contract.
//
// The protocol (docs/architecture.md):
//  - every tile has a version that grows with every change; a message carries the tile whole
//    (MapTile, transient-local: a late joiner gets the newest whole copy of each tile) or as a
//    delta (MapTileDelta, volatile: the counter differences against `base_version`, applied
//    only by a follower that holds exactly that version);
//  - the summary (MapMeta) gives the layout, the tile bounds, the tile count, the sum of all
//    tile versions and whether the map is complete; a follower whose tiles add up to that sum
//    holds the leader's map;
//  - a map is named by its map id and epoch: a leader that starts a new map bumps the epoch, and
//    a follower drops older epochs.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/tile_codec.hpp"

namespace esfleet::mapshare {

/// Every message carries this; receivers reject any other (idl: msg::kProtocolVersion, and
/// dds/ checks that the two agree at compile time).
inline constexpr std::uint16_t kProtocolVersion = 3;

/// Which map a message belongs to.
struct MapIdentity {
  std::string map_id = "map";
  std::uint32_t epoch = 1;
};

/// One tile of the leader's map, whole or as a delta.
struct TileMessage {
  std::string map_id;
  std::int32_t tx = 0;  ///< tile column: cells [tx * tile_edge, (tx + 1) * tile_edge)
  std::int32_t ty = 0;  ///< tile row
  std::uint16_t protocol = kProtocolVersion;
  std::uint32_t epoch = 0;
  std::uint64_t version = 0;  ///< the tile's version (after applying, for a delta)
  /// Set for a delta: the version the differences are relative to (< version).
  std::optional<std::uint64_t> base_version;
  float cell_size = 0.0f;       ///< metres per cell edge
  std::uint16_t tile_edge = 0;  ///< cells per tile edge
  std::uint8_t encoding = 0;    ///< a TileEncoding value, as received (may be unknown)
  std::uint32_t cells = 0;      ///< tile_edge^2
  /// Encoded hit and err counters (whole) or their differences now - base (delta).
  std::vector<std::uint8_t> payload;
  std::uint64_t stamp_ns = 0;  ///< the leader's CLOCK_REALTIME when it published

  bool is_delta() const { return base_version.has_value(); }
  TileKey key() const { return {tx, ty}; }
};

/// The summary of one map.
struct MetaMessage {
  std::string map_id;
  std::uint16_t protocol = kProtocolVersion;
  std::uint32_t epoch = 0;
  float cell_size = 0.0f;
  std::uint16_t tile_edge = 0;
  std::int32_t min_tx = 0;  ///< tile bounds, inclusive (0 when there is no tile)
  std::int32_t min_ty = 0;
  std::int32_t max_tx = 0;
  std::int32_t max_ty = 0;
  std::uint32_t tile_count = 0;
  std::uint64_t map_version = 0;  ///< sum of the versions of all tiles (map_version())
  bool complete = false;          ///< the leader's input has ended: the map is final
  std::uint32_t scans = 0;        ///< scans the leader has processed
  std::string params;             ///< JSON of the leader's parameters
  std::uint64_t stamp_ns = 0;
};

/// The longest payload a valid tile of `cells` cells can have: zlib's deflateBound of the
/// longest inflated stream, 2 * kMaxVarintBytes bytes per cell (kRaw's 8 are less).
constexpr std::size_t max_payload_bytes(std::size_t cells) {
  const std::size_t n = 2 * kMaxVarintBytes * cells;
  return n + (n >> 12) + (n >> 14) + (n >> 25) + 64;
}
/// The longest payload of any valid tile (the largest, kMaxTileCells): followers drop longer
/// samples before queueing them.
inline constexpr std::size_t kMaxTilePayloadBytes = max_payload_bytes(kMaxTileCells);

/// What a tile message takes of the map besides the tile: the layout.
struct TileLayout {
  float cell_size = 0.0f;       ///< metres per cell edge
  std::uint16_t tile_edge = 0;  ///< cells per tile edge
  std::uint32_t cells = 0;      ///< tile_edge^2
};
TileLayout tile_layout(const GridMap& map);

/// The counters of one tile at one version, viewed: a Tile of a map, or a copy of one that a
/// publisher thread encodes while the map moves on (leader/map_publisher.hpp).
struct TileCounters {
  TileKey key;
  std::uint64_t version = 0;
  std::span<const std::uint32_t> hit;
  std::span<const std::uint32_t> err;
};
inline TileCounters counters_of(const Tile& tile) {
  return {tile.key, tile.version, tile.hit, tile.err};
}

/// `tile` whole, in `layout`, its payload encoded with `encoding`; stamped `stamp_ns`.
TileMessage whole_tile_message(const TileLayout& layout, const TileCounters& tile,
                               const MapIdentity& id, TileEncoding encoding,
                               std::uint64_t stamp_ns);
/// `tile` as a delta against the counters `base_hit`, `base_err` it had at `base_version`
/// (< tile.version): the per-cell differences now - base (modulo 2^32). Throws
/// std::invalid_argument for base spans of the wrong size or a base version not older than the
/// tile's.
TileMessage delta_tile_message(const TileLayout& layout, const TileCounters& tile,
                               std::uint64_t base_version, std::span<const std::uint32_t> base_hit,
                               std::span<const std::uint32_t> base_err, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns);

/// `tile` (one of `map`'s: its layout comes from the map) whole, its payload encoded with
/// `encoding`; stamped `stamp_ns`.
TileMessage whole_tile_message(const GridMap& map, const Tile& tile, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns);
/// The same for tile `key` of `map`. Throws std::invalid_argument for a missing tile.
TileMessage whole_tile_message(const GridMap& map, TileKey key, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns);

/// `tile` (one of `map`'s) as a delta against the counters `base_hit`, `base_err` it had at
/// `base_version` (< the tile's version): the per-cell differences now - base (modulo 2^32).
/// Throws std::invalid_argument for base spans of the wrong size or a base version not older
/// than the tile's.
TileMessage delta_tile_message(const GridMap& map, const Tile& tile, std::uint64_t base_version,
                               std::span<const std::uint32_t> base_hit,
                               std::span<const std::uint32_t> base_err, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns);
/// The same for tile `key` of `map`; also throws std::invalid_argument for a missing tile.
TileMessage delta_tile_message(const GridMap& map, TileKey key, std::uint64_t base_version,
                               std::span<const std::uint32_t> base_hit,
                               std::span<const std::uint32_t> base_err, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns);

/// The summary of `map`: layout, the bounds of its tiles, tile count, map_version().
MetaMessage meta_message(const GridMap& map, const MapIdentity& id, bool complete,
                         std::uint32_t scans, std::string params, std::uint64_t stamp_ns);

/// Sum of the versions of all tiles: grows whenever any tile changes, equal on leader and
/// follower once the follower holds every tile at its newest version.
std::uint64_t map_version(const GridMap& map);

}  // namespace esfleet::mapshare
