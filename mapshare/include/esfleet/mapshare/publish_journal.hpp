#pragma once
// The leader's promise about what followers may hold, kept so that a leader restarted after a
// crash can supersede it: no tile version above the ceiling, no tile key outside the set.
// The leader persists the journal BEFORE a publish that would break it (leader/checkpoint.hpp
// writes it to disk), so the journal covers what followers hold however old its last
// checkpoint is. A resumed leader gives every tile a version above the ceiling, and creates the
// tiles it lacks empty, so every tile a follower holds is replaced by a newer version.

#include <cstdint>
#include <set>

#include "esfleet/core/grid_map.hpp"

namespace esfleet::mapshare {

/// Versions reserved at a time: the journal is rewritten when a tile version passes the ceiling.
inline constexpr std::uint64_t kVersionHeadroom = 1000;

struct PublishJournal {
  std::uint64_t version_ceiling = 0;
  std::set<TileKey> keys;

  /// Before publishing `map`: when a tile's version is above the ceiling or its key is not in
  /// the journal, raises the ceiling to the highest version + kVersionHeadroom, adds every key
  /// and returns true (the caller must persist the journal before it publishes); false when the
  /// journal already covers the map.
  bool reserve(const GridMap& map);
};

/// What superseding a published map did.
struct Superseded {
  std::uint64_t new_version = 0;        ///< every tile's version now
  std::uint64_t tiles_added_empty = 0;  ///< journal keys the map lacked, created empty
};

/// A resumed leader's map (restored from its last checkpoint) over what the dead leader may
/// have published (`journal`): every tile takes version ceiling + 1, journal tiles the map
/// lacks are created empty at that version, and the journal's ceiling is raised past it (by
/// kVersionHeadroom) and its keys completed. Throws std::invalid_argument when a tile of `map`
/// is already above the ceiling (a journal older than the map cannot be).
Superseded supersede(GridMap& map, PublishJournal& journal);

}  // namespace esfleet::mapshare
