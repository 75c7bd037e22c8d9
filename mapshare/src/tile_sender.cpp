#include "esfleet/mapshare/tile_sender.hpp"

namespace esfleet::mapshare {

TileSender::TileSender(MapIdentity id, TileEncoding encoding, DeltaPolicy policy)
    : id_(std::move(id)), encoding_(encoding), policy_(policy) {}

Publication TileSender::publish(GridMap& map, double stamp, bool complete, bool reader_joined,
                                std::uint32_t scans, const std::string& params,
                                std::uint64_t now_ns) {
  Publication out;
  for (const TileKey k : map.take_dirty()) {
    const Tile* tile = map.find_tile(k);
    if (tile == nullptr) continue;
    auto [it, is_new] = sent_.try_emplace(k);
    Sent& sent = it->second;
    if (!is_new && sent.version >= tile->version) continue;  // nothing new since the last send
    const bool whole = is_new || complete || sent.deltas_since_full + 1 >= policy_.full_every ||
                       stamp - sent.full_stamp >= policy_.full_period;
    out.tiles.push_back(make(map, *tile, sent, whole, stamp, now_ns));
  }
  out.joiner_refresh = reader_joined;
  if (complete || reader_joined) {
    for (auto& [k, sent] : sent_) {
      const Tile* tile = map.find_tile(k);
      if (sent.full_version < sent.version && tile != nullptr) {
        out.tiles.push_back(make(map, *tile, sent, true, stamp, now_ns));
      }
    }
  }
  out.meta = meta_message(map, id_, complete, scans, params, now_ns);
  return out;
}

void TileSender::republish_all(GridMap& map) {
  sent_.clear();
  map.mark_all_dirty();
}

TileMessage TileSender::make(const GridMap& map, const Tile& tile, Sent& sent, bool whole,
                             double stamp, std::uint64_t now_ns) {
  TileMessage m;
  if (whole) {
    m = whole_tile_message(map, tile, id_, encoding_, now_ns);
    sent.full_version = tile.version;
    sent.full_stamp = stamp;
    sent.deltas_since_full = 0;
  } else {
    m = delta_tile_message(map, tile, sent.version, sent.hit, sent.err, id_, encoding_, now_ns);
    ++sent.deltas_since_full;
  }
  // The next delta builds on what the map holds now, whether or not the transport delivers
  // this one: a follower that misses a link of the chain waits for the next whole tile.
  sent.version = tile.version;
  sent.hit = tile.hit;
  sent.err = tile.err;
  return m;
}

}  // namespace esfleet::mapshare
