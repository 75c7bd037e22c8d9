// Map messages and the follower's replica, without a network: a replica fed the leader's tile
// messages must hold counters equal to the leader's; anything malformed is rejected with a
// reason and leaves the replica untouched.

#include "esfleet/dds/map_convert.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "esfleet/core/tile_codec.hpp"

namespace esfleet::dds {
namespace {

/// A leader map with random counters over a few tiles (including negative keys).
GridMap random_map(unsigned seed, int updates = 3000) {
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

void send_all(const GridMap& leader, MapReplica& replica, const MapIdentity& id,
              TileEncoding enc = TileEncoding::kVarintZlib) {
  for (const TileKey k : leader.tile_keys()) {
    std::string error;
    ASSERT_EQ(replica.apply(tile_to_msg(leader, k, id, enc, 1), &error), Applied::kApplied)
        << error;
  }
}

TEST(MapReplica, RebuildsTheLeadersCountersExactly) {
  for (unsigned seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const GridMap leader = random_map(seed);
    for (TileEncoding enc : {TileEncoding::kRaw, TileEncoding::kVarintZlib}) {
      MapReplica replica;
      send_all(leader, replica, {}, enc);
      ASSERT_TRUE(replica.has_map());
      EXPECT_EQ(map_digest(replica.map()), map_digest(leader));
      EXPECT_EQ(map_version(replica.map()), map_version(leader));
    }
  }
}

TEST(MapReplica, CompleteOnlyWithEveryTileAtTheNewestVersion) {
  GridMap leader = random_map(4);
  MapReplica replica;
  const MapIdentity id;
  const auto keys = leader.tile_keys();
  ASSERT_GT(keys.size(), 2u);
  EXPECT_EQ(replica.apply(meta_to_msg(leader, id, true, 10, "{}", 1)), Applied::kApplied);
  EXPECT_FALSE(replica.complete());
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
    replica.apply(tile_to_msg(leader, keys[i], id, TileEncoding::kVarintZlib, 1));
  }
  EXPECT_FALSE(replica.complete());  // one tile missing
  replica.apply(tile_to_msg(leader, keys.back(), id, TileEncoding::kVarintZlib, 1));
  EXPECT_TRUE(replica.complete());

  // The leader changes a tile and says so: incomplete until the new version arrives.
  leader.add_hit({0, 0});
  leader.commit_update();
  replica.apply(meta_to_msg(leader, id, true, 11, "{}", 2));
  EXPECT_FALSE(replica.complete());
  replica.apply(tile_to_msg(leader, leader.tile_of({0, 0}), id, TileEncoding::kVarintZlib, 2));
  EXPECT_TRUE(replica.complete());
  EXPECT_EQ(map_digest(replica.map()), map_digest(leader));
}

TEST(MapReplica, OlderOrEqualVersionsAreStale) {
  GridMap leader = random_map(5);
  const TileKey k = leader.tile_keys().front();
  const msg::MapTile v1 = tile_to_msg(leader, k, {}, TileEncoding::kVarintZlib, 1);
  leader.add_hit({k.tx * 64, k.ty * 64});
  leader.commit_update();
  const msg::MapTile v2 = tile_to_msg(leader, k, {}, TileEncoding::kVarintZlib, 2);
  MapReplica replica;
  EXPECT_EQ(replica.apply(v2), Applied::kApplied);
  EXPECT_EQ(replica.apply(v1), Applied::kStale);
  EXPECT_EQ(replica.apply(v2), Applied::kStale);
  EXPECT_EQ(replica.map().find_tile(k)->hit, leader.find_tile(k)->hit);
}

TEST(MapReplica, OtherMapsAndOlderEpochsAreIgnoredANewerEpochRestarts) {
  const GridMap a = random_map(6), b = random_map(7, 500);
  MapReplica replica("fleet");
  const TileKey ka = a.tile_keys().front();
  EXPECT_EQ(replica.apply(tile_to_msg(a, ka, {"other", 1}, TileEncoding::kRaw, 1)),
            Applied::kIgnored);
  EXPECT_FALSE(replica.has_map());
  send_all(a, replica, {"fleet", 2});
  EXPECT_EQ(
      replica.apply(tile_to_msg(b, b.tile_keys().front(), {"fleet", 1}, TileEncoding::kRaw, 1)),
      Applied::kIgnored);
  send_all(b, replica, {"fleet", 3});  // the leader restarted with a new map
  EXPECT_EQ(replica.epoch(), 3u);
  EXPECT_EQ(map_digest(replica.map()), map_digest(b));
}

TEST(MapReplica, MalformedTilesAreRejectedWithAReasonAndChangeNothing) {
  const GridMap leader = random_map(8);
  MapReplica replica;
  send_all(leader, replica, {});
  const std::string before = map_digest(replica.map());
  const msg::MapTile good =
      tile_to_msg(leader, leader.tile_keys().front(), {}, TileEncoding::kVarintZlib, 1);

  struct Case {
    const char* name;
    std::function<void(msg::MapTile&)> spoil;
    const char* expect;
  };
  const std::vector<Case> cases = {
      {"protocol", [](msg::MapTile& t) { t.protocol(9); }, "protocol 9"},
      {"cells", [](msg::MapTile& t) { t.cells(100); }, "cells 100"},
      {"tile edge", [](msg::MapTile& t) { t.tile_edge(63); }, "tile_edge 63"},
      {"tile edge change", [](msg::MapTile& t) { t.tile_edge(32); }, "differs"},
      {"cell size", [](msg::MapTile& t) { t.cell_size(std::nanf("")); }, "cell_size"},
      {"cell size change", [](msg::MapTile& t) { t.cell_size(0.1f); }, "differs"},
      {"key", [](msg::MapTile& t) { t.tx(5000000); }, "outside"},
      {"encoding", [](msg::MapTile& t) { t.encoding(7); }, "unknown encoding 7"},
      {"payload", [](msg::MapTile& t) { t.payload().resize(t.payload().size() / 2); }, "zlib"},
  };
  for (const Case& c : cases) {
    msg::MapTile bad = good;
    bad.version(good.version() + 100);  // newer, so only validation can stop it
    c.spoil(bad);
    std::string error;
    EXPECT_EQ(replica.apply(bad, &error), Applied::kRejected) << c.name;
    EXPECT_NE(error.find(c.expect), std::string::npos) << c.name << ": " << error;
  }
  EXPECT_EQ(map_digest(replica.map()), before);
}

TEST(MapMessages, MetaDescribesTheMap) {
  const GridMap leader = random_map(9);
  const msg::MapMeta m = meta_to_msg(leader, {"m", 4}, false, 77, "{\"mu\":100}", 5);
  EXPECT_EQ(m.map_id().to_string(), "m");
  EXPECT_EQ(m.epoch(), 4u);
  EXPECT_EQ(m.tile_count(), leader.tile_count());
  EXPECT_EQ(m.map_version(), map_version(leader));
  EXPECT_EQ(m.scans(), 77u);
  EXPECT_FALSE(m.complete());
  for (const TileKey k : leader.tile_keys()) {
    EXPECT_GE(k.tx, m.min_tx());
    EXPECT_LE(k.tx, m.max_tx());
    EXPECT_GE(k.ty, m.min_ty());
    EXPECT_LE(k.ty, m.max_ty());
  }
  const msg::MapMeta long_params = meta_to_msg(leader, {}, false, 0, std::string(5000, 'x'), 0);
  EXPECT_EQ(long_params.es_params().size(), 1024u);
}

TEST(MapMessages, ScanRoundTripAndValidation) {
  LaserScan s;
  s.stamp = 12.5;
  s.angle_min = -1.5f;
  s.angle_increment = 0.01f;
  s.max_range = 30.0f;
  s.ranges = {1.0f, 2.0f, 81.9f};
  s.odometry = Pose2{1, 2, 0.5};
  const LaserScan back = scan_from_msg(scan_to_msg("r1", 3, s));
  EXPECT_EQ(back.ranges, s.ranges);
  EXPECT_EQ(back.stamp, s.stamp);
  ASSERT_TRUE(back.odometry.has_value());
  EXPECT_EQ(*back.odometry, *s.odometry);

  msg::LaserScanMsg m = scan_to_msg("r1", 3, s);
  m.ranges().clear();
  EXPECT_THROW(scan_from_msg(m), std::invalid_argument);
  m = scan_to_msg("r1", 3, s);
  m.angle_increment(std::nanf(""));
  EXPECT_THROW(scan_from_msg(m), std::invalid_argument);
  m = scan_to_msg("r1", 3, s);
  m.ranges().resize(20000, 1.0f);
  EXPECT_THROW(scan_from_msg(m), std::invalid_argument);
}

}  // namespace
}  // namespace esfleet::dds
