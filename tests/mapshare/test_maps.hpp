#pragma once
// Seeded leader maps for the map-sharing tests.

#include <random>
#include <vector>

#include "esfleet/core/grid_map.hpp"

namespace esfleet::mapshare::test {

/// `updates` random hits, misses and removals in a 300 x 300 cell area around the origin (a few
/// tiles, negative keys included; removals make differences negative modulo 2^32), one commit.
inline void change_map(GridMap& map, std::mt19937& gen, int updates) {
  std::uniform_int_distribution<int> cell(-150, 150);
  for (int i = 0; i < updates; ++i) {
    const CellIndex c{cell(gen), cell(gen)};
    switch (gen() % 5) {
      case 0:
        map.add_hit(c);
        break;
      case 1:
        map.remove_err(c);
        break;
      case 2:
        map.remove_hit(c);
        break;
      default:
        map.add_err(c);
    }
  }
  map.commit_update();
}

/// A leader map with `updates` random hits and misses over a few tiles (negative keys too).
inline GridMap random_map(unsigned seed, int updates = 3000) {
  GridMap map;
  std::mt19937 gen(seed);
  std::uniform_int_distribution<int> cell(-150, 150);
  for (int i = 0; i < updates; ++i) {
    const CellIndex c{cell(gen), cell(gen)};
    if (gen() % 3 == 0) {
      map.add_hit(c);
    } else {
      map.add_err(c);
    }
  }
  map.commit_update();
  return map;
}

/// A copy of `map`'s tiles (counters and versions) in a new map of the same layout.
inline GridMap copy_of(const GridMap& map) {
  GridMap out(map.config());
  for (const TileKey k : map.tile_keys()) {
    const Tile& t = *map.find_tile(k);
    out.set_tile(k, t.version, t.hit, t.err);
  }
  out.take_dirty();
  return out;
}

}  // namespace esfleet::mapshare::test
