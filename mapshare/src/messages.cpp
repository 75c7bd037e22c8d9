#include "esfleet/mapshare/messages.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

namespace esfleet::mapshare {

namespace {
const Tile& tile_or_throw(const GridMap& map, TileKey key) {
  const Tile* tile = map.find_tile(key);
  if (tile == nullptr) {
    throw std::invalid_argument("no tile (" + std::to_string(key.tx) + ", " +
                                std::to_string(key.ty) + ") in the map");
  }
  return *tile;
}

/// Identity, key, version and layout of `tile`, and `hit`/`err` encoded as the payload.
TileMessage tile_message(const TileLayout& layout, const TileCounters& tile, const MapIdentity& id,
                         std::span<const std::uint32_t> hit, std::span<const std::uint32_t> err,
                         TileEncoding encoding, std::uint64_t stamp_ns) {
  TileMessage m;
  m.map_id = id.map_id;
  m.tx = tile.key.tx;
  m.ty = tile.key.ty;
  m.epoch = id.epoch;
  m.version = tile.version;
  m.cell_size = layout.cell_size;
  m.tile_edge = layout.tile_edge;
  m.cells = layout.cells;
  EncodedTile e = encode_tile(hit, err, encoding);
  m.encoding = static_cast<std::uint8_t>(e.encoding);
  m.payload = std::move(e.payload);
  m.stamp_ns = stamp_ns;
  return m;
}
}  // namespace

TileLayout tile_layout(const GridMap& map) {
  return {static_cast<float>(map.cell_size()), static_cast<std::uint16_t>(map.tile_edge()),
          static_cast<std::uint32_t>(map.cells_per_tile())};
}

TileMessage whole_tile_message(const TileLayout& layout, const TileCounters& tile,
                               const MapIdentity& id, TileEncoding encoding,
                               std::uint64_t stamp_ns) {
  return tile_message(layout, tile, id, tile.hit, tile.err, encoding, stamp_ns);
}

TileMessage whole_tile_message(const GridMap& map, const Tile& tile, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns) {
  return whole_tile_message(tile_layout(map), counters_of(tile), id, encoding, stamp_ns);
}

TileMessage whole_tile_message(const GridMap& map, TileKey key, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns) {
  return whole_tile_message(map, tile_or_throw(map, key), id, encoding, stamp_ns);
}

TileMessage delta_tile_message(const GridMap& map, TileKey key, std::uint64_t base_version,
                               std::span<const std::uint32_t> base_hit,
                               std::span<const std::uint32_t> base_err, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns) {
  return delta_tile_message(map, tile_or_throw(map, key), base_version, base_hit, base_err, id,
                            encoding, stamp_ns);
}

TileMessage delta_tile_message(const GridMap& map, const Tile& tile, std::uint64_t base_version,
                               std::span<const std::uint32_t> base_hit,
                               std::span<const std::uint32_t> base_err, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns) {
  return delta_tile_message(tile_layout(map), counters_of(tile), base_version, base_hit, base_err,
                            id, encoding, stamp_ns);
}

TileMessage delta_tile_message(const TileLayout& layout, const TileCounters& tile,
                               std::uint64_t base_version, std::span<const std::uint32_t> base_hit,
                               std::span<const std::uint32_t> base_err, const MapIdentity& id,
                               TileEncoding encoding, std::uint64_t stamp_ns) {
  if (base_hit.size() != tile.hit.size() || base_err.size() != tile.err.size()) {
    throw std::invalid_argument("delta base has " + std::to_string(base_hit.size()) +
                                " cells, the tile " + std::to_string(tile.hit.size()));
  }
  if (base_version >= tile.version) {
    throw std::invalid_argument("delta base version " + std::to_string(base_version) +
                                " is not older than the tile's " + std::to_string(tile.version));
  }
  std::vector<std::uint32_t> dhit(tile.hit.size()), derr(tile.err.size());
  for (std::size_t i = 0; i < dhit.size(); ++i) {
    dhit[i] = tile.hit[i] - base_hit[i];  // modulo 2^32: counters may also decrease
    derr[i] = tile.err[i] - base_err[i];
  }
  TileMessage m = tile_message(layout, tile, id, dhit, derr, encoding, stamp_ns);
  m.base_version = base_version;
  return m;
}

MetaMessage meta_message(const GridMap& map, const MapIdentity& id, bool complete,
                         std::uint32_t scans, std::string params, std::uint64_t stamp_ns) {
  MetaMessage m;
  m.map_id = id.map_id;
  m.epoch = id.epoch;
  m.cell_size = static_cast<float>(map.cell_size());
  m.tile_edge = static_cast<std::uint16_t>(map.tile_edge());
  const std::vector<TileKey> keys = map.tile_keys();
  if (!keys.empty()) {
    m.min_tx = m.max_tx = keys.front().tx;
    m.min_ty = m.max_ty = keys.front().ty;
  }
  for (const TileKey k : keys) {  // one pass: bounds and the version sum (map_version)
    m.min_tx = std::min(m.min_tx, k.tx);
    m.max_tx = std::max(m.max_tx, k.tx);
    m.min_ty = std::min(m.min_ty, k.ty);
    m.max_ty = std::max(m.max_ty, k.ty);
    m.map_version += map.find_tile(k)->version;
  }
  m.tile_count = static_cast<std::uint32_t>(keys.size());
  m.complete = complete;
  m.scans = scans;
  m.params = std::move(params);
  m.stamp_ns = stamp_ns;
  return m;
}

std::uint64_t map_version(const GridMap& map) {
  std::uint64_t sum = 0;
  for (const TileKey k : map.tile_keys()) sum += map.find_tile(k)->version;
  return sum;
}

}  // namespace esfleet::mapshare
