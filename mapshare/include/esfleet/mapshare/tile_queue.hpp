#pragma once
// The changed tiles a publisher has still to send, coalesced: at most one copy per tile, the
// newest. The mapping thread puts copies of the tiles it changed (put_changed: the counters
// only, a memcpy per tile); the publisher thread takes them all when it is ready for more
// (take_all) and encodes them with a TileSender, whose deltas are against what it last sent, so
// however many versions were replaced in the queue the followers get one exact delta or whole
// tile. Memory is bounded by the map: one entry per tile. Not thread-safe: the caller locks.

#include <cstddef>
#include <cstdint>
#include <map>
#include <vector>

#include "esfleet/core/grid_map.hpp"
#include "esfleet/mapshare/messages.hpp"

namespace esfleet::mapshare {

/// A copy of one tile's counters at one version, handed over at wall clock `stamp_ns`.
struct TileCopy {
  TileKey key;
  std::uint64_t version = 0;
  std::vector<std::uint32_t> hit;
  std::vector<std::uint32_t> err;
  std::uint64_t stamp_ns = 0;

  TileCounters counters() const { return {key, version, hit, err}; }
};

class TileQueue {
 public:
  /// Copies every tile of `map` changed since the last call (GridMap::take_dirty) into the
  /// queue; a tile already waiting keeps its place and takes the newer counters (counted in
  /// coalesced()). Returns the number of tiles copied.
  std::size_t put_changed(GridMap& map, std::uint64_t stamp_ns);
  /// Every waiting tile, in the order each first came in since the last take; empties the
  /// queue.
  std::vector<TileCopy> take_all();

  std::size_t size() const { return waiting_.size(); }
  bool empty() const { return waiting_.empty(); }
  /// Copies replaced by a newer one before they were taken.
  std::uint64_t coalesced() const { return coalesced_; }
  /// Most tiles waiting at once.
  std::size_t high_water() const { return high_water_; }

 private:
  struct Entry {
    std::uint64_t order = 0;  ///< when the tile first came in since the last take
    TileCopy copy;
  };
  std::map<TileKey, Entry> waiting_;
  std::uint64_t next_order_ = 0;
  std::uint64_t coalesced_ = 0;
  std::size_t high_water_ = 0;
};

}  // namespace esfleet::mapshare
