#include "esfleet/mapshare/tile_queue.hpp"

#include <algorithm>

namespace esfleet::mapshare {

std::size_t TileQueue::put_changed(GridMap& map, std::uint64_t stamp_ns) {
  std::size_t copied = 0;
  for (const TileKey k : map.take_dirty()) {
    const Tile* tile = map.find_tile(k);
    if (tile == nullptr) continue;
    auto [it, is_new] = waiting_.try_emplace(k);
    Entry& e = it->second;
    if (is_new) {
      e.order = next_order_++;
    } else {
      ++coalesced_;
    }
    e.copy.key = k;
    e.copy.version = tile->version;
    e.copy.hit.assign(tile->hit.begin(), tile->hit.end());  // reuses the older copy's storage
    e.copy.err.assign(tile->err.begin(), tile->err.end());
    e.copy.stamp_ns = stamp_ns;
    ++copied;
  }
  high_water_ = std::max(high_water_, waiting_.size());
  return copied;
}

std::vector<TileCopy> TileQueue::take_all() {
  std::vector<Entry*> entries;
  entries.reserve(waiting_.size());
  for (auto& [k, e] : waiting_) entries.push_back(&e);
  std::sort(entries.begin(), entries.end(),
            [](const Entry* a, const Entry* b) { return a->order < b->order; });
  std::vector<TileCopy> out;
  out.reserve(entries.size());
  for (Entry* e : entries) out.push_back(std::move(e->copy));
  waiting_.clear();
  return out;
}

}  // namespace esfleet::mapshare
