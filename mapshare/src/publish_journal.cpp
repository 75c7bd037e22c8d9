#include "esfleet/mapshare/publish_journal.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

namespace esfleet::mapshare {

bool PublishJournal::reserve(const GridMap& map) {
  std::uint64_t max_version = 0;
  bool new_key = false;
  const std::vector<TileKey> tile_keys = map.tile_keys();
  for (const TileKey k : tile_keys) {
    max_version = std::max(max_version, map.find_tile(k)->version);
    if (!new_key && !keys.contains(k)) new_key = true;
  }
  if (max_version <= version_ceiling && !new_key) return false;
  version_ceiling = std::max(version_ceiling, max_version + kVersionHeadroom);
  keys.insert(tile_keys.begin(), tile_keys.end());
  return true;
}

Superseded supersede(GridMap& map, PublishJournal& journal) {
  Superseded s;
  s.new_version = journal.version_ceiling + 1;
  for (const TileKey k : map.tile_keys()) {
    if (map.find_tile(k)->version > journal.version_ceiling) {
      throw std::invalid_argument("version_ceiling " + std::to_string(journal.version_ceiling) +
                                  " is below a checkpointed tile version");
    }
  }
  const std::vector<std::uint32_t> zeros(map.cells_per_tile(), 0);
  for (const TileKey k : journal.keys) {
    if (map.find_tile(k) == nullptr) {
      map.set_tile(k, s.new_version, zeros, zeros);
      ++s.tiles_added_empty;
    }
  }
  for (const TileKey k : map.tile_keys()) {
    const Tile& t = *map.find_tile(k);
    const std::vector<std::uint32_t> hit = t.hit, err = t.err;
    map.set_tile(k, s.new_version, hit, err);
  }
  journal.version_ceiling = s.new_version + kVersionHeadroom;
  for (const TileKey k : map.tile_keys()) journal.keys.insert(k);
  return s;
}

}  // namespace esfleet::mapshare
