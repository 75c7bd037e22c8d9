#pragma once
// Map helpers the benchmarks share.

#include <algorithm>

#include "esfleet/core/grid_map.hpp"

namespace esfleet::bench {

/// A copy of `src` with the coarse levels the localiser needs (what a follower rebuilds).
inline GridMap copy_map(const GridMap& src, int pyramid_levels) {
  GridMapConfig c = src.config();
  c.pyramid_levels = std::max(c.pyramid_levels, pyramid_levels);
  GridMap out(c);
  for (const TileKey k : src.tile_keys()) {
    const Tile* t = src.find_tile(k);
    out.set_tile(k, t->version, t->hit, t->err);
  }
  return out;
}

}  // namespace esfleet::bench
