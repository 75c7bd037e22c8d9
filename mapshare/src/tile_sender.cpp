#include "esfleet/mapshare/tile_sender.hpp"

namespace esfleet::mapshare {

TileSender::TileSender(MapIdentity id, TileEncoding encoding, DeltaPolicy policy)
    : id_(std::move(id)), encoding_(encoding), policy_(policy) {}

Publication TileSender::publish(GridMap& map, double stamp, bool complete, bool reader_joined,
                                std::uint32_t scans, const std::string& params,
                                std::uint64_t now_ns) {
  Publication out;
  const TileLayout layout = tile_layout(map);
  for (const TileKey k : map.take_dirty()) {
    const Tile* tile = map.find_tile(k);
    if (tile == nullptr) continue;
    if (auto m = send(layout, counters_of(*tile), stamp, complete, now_ns)) {
      out.tiles.push_back(std::move(*m));
    }
  }
  out.joiner_refresh = reader_joined;
  if (complete || reader_joined) refresh_whole(layout, stamp, now_ns, out.tiles);
  out.meta = meta_message(map, id_, complete, scans, params, now_ns);
  return out;
}

std::optional<TileMessage> TileSender::send(const TileLayout& layout, const TileCounters& tile,
                                            double stamp, bool complete, std::uint64_t stamp_ns) {
  auto [it, is_new] = sent_.try_emplace(tile.key);
  Sent& sent = it->second;
  if (!is_new && sent.version >= tile.version) return std::nullopt;  // nothing new since
  const bool whole = is_new || complete || sent.deltas_since_full + 1 >= policy_.full_every ||
                     stamp - sent.full_stamp >= policy_.full_period;
  return make(layout, tile, sent, whole, stamp, stamp_ns);
}

void TileSender::refresh_whole(const TileLayout& layout, double stamp, std::uint64_t now_ns,
                               std::vector<TileMessage>& out) {
  // What was sent last is the newest version the sender knows (publish() sent every changed
  // tile first), so the whole copy is made from it.
  for (auto& [k, sent] : sent_) {
    if (sent.full_version < sent.version) {
      out.push_back(make(layout, {k, sent.version, sent.hit, sent.err}, sent, true, stamp, now_ns));
    }
  }
}

void TileSender::republish_all(GridMap& map) {
  sent_.clear();
  map.mark_all_dirty();
}

TileMessage TileSender::make(const TileLayout& layout, const TileCounters& tile, Sent& sent,
                             bool whole, double stamp, std::uint64_t now_ns) {
  TileMessage m;
  if (whole) {
    m = whole_tile_message(layout, tile, id_, encoding_, now_ns);
    sent.full_version = tile.version;
    sent.full_stamp = stamp;
    sent.deltas_since_full = 0;
  } else {
    m = delta_tile_message(layout, tile, sent.version, sent.hit, sent.err, id_, encoding_, now_ns);
    ++sent.deltas_since_full;
  }
  // The next delta builds on what the map holds now, whether or not the transport delivers
  // this one: a follower that misses a link of the chain waits for the next whole tile.
  sent.version = tile.version;
  if (tile.hit.data() != sent.hit.data()) {  // refresh_whole passes `sent`'s own counters
    sent.hit.assign(tile.hit.begin(), tile.hit.end());
    sent.err.assign(tile.err.begin(), tile.err.end());
  }
  return m;
}

}  // namespace esfleet::mapshare
