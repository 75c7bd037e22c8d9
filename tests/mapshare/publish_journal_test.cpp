// The publish journal: when it must be persisted, and what superseding does to a resumed map.

#include "esfleet/mapshare/publish_journal.hpp"

#include <gtest/gtest.h>

#include <stdexcept>

namespace esfleet::mapshare {
namespace {

TEST(PublishJournal, ReserveReportsWhenTheMapOutgrowsIt) {
  GridMap map;
  PublishJournal j;
  EXPECT_FALSE(j.reserve(map));  // an empty map needs nothing
  map.add_hit({1, 1});
  map.commit_update();
  ASSERT_TRUE(j.reserve(map));  // a new key
  EXPECT_EQ(j.version_ceiling, map.find_tile(map.tile_of({1, 1}))->version + kVersionHeadroom);
  EXPECT_EQ(j.keys.size(), 1u);
  for (int i = 0; i < 10; ++i) {
    map.add_hit({1, 1});
    map.commit_update();
  }
  EXPECT_FALSE(j.reserve(map));  // versions still below the ceiling, no new key
  map.add_hit({500, 500});
  map.commit_update();
  EXPECT_TRUE(j.reserve(map));  // a new key
  EXPECT_EQ(j.keys.size(), 2u);
  const std::uint64_t ceiling = j.version_ceiling;
  GridMap past(map.config());
  const Tile& t = *map.find_tile(map.tile_of({1, 1}));
  past.set_tile(t.key, ceiling + 1, t.hit, t.err);
  EXPECT_TRUE(j.reserve(past));  // a version past the ceiling
  EXPECT_EQ(j.version_ceiling, ceiling + 1 + kVersionHeadroom);
}

TEST(PublishJournal, SupersedeLiftsEveryTileAboveTheCeilingAndAddsMissingOnesEmpty) {
  GridMap map;
  map.add_hit({1, 1});
  map.commit_update();
  PublishJournal j;
  j.version_ceiling = 5000;
  j.keys = {map.tile_of({1, 1}), TileKey{7, -3}};
  const auto hit_before = map.find_tile(map.tile_of({1, 1}))->hit;
  const Superseded s = supersede(map, j);
  EXPECT_EQ(s.new_version, 5001u);
  EXPECT_EQ(s.tiles_added_empty, 1u);
  EXPECT_EQ(map.find_tile(map.tile_of({1, 1}))->version, 5001u);
  EXPECT_EQ(map.find_tile(map.tile_of({1, 1}))->hit, hit_before);  // counters kept
  const Tile* empty = map.find_tile({7, -3});
  ASSERT_NE(empty, nullptr);
  EXPECT_EQ(empty->version, 5001u);
  EXPECT_TRUE(std::all_of(empty->hit.begin(), empty->hit.end(), [](auto v) { return v == 0; }));
  EXPECT_EQ(j.version_ceiling, 5001u + kVersionHeadroom);
}

TEST(PublishJournal, SupersedeRefusesAMapAboveTheCeiling) {
  GridMap map;
  map.add_hit({1, 1});
  map.commit_update();
  PublishJournal j;  // ceiling 0: older than the map
  EXPECT_THROW(supersede(map, j), std::invalid_argument);
}

}  // namespace
}  // namespace esfleet::mapshare
