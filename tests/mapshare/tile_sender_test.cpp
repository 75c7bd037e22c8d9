// The leader's sending step alone: which changed tiles go out whole and which as deltas, what a
// complete map and a joining reader add, and that unchanged tiles are not sent.

#include "esfleet/mapshare/tile_sender.hpp"

#include <gtest/gtest.h>

#include <map>

#include "test_maps.hpp"

namespace esfleet::mapshare {
namespace {

/// Whole tiles and deltas of one publication, by key.
struct Sorted {
  std::map<TileKey, int> whole, delta;
};
Sorted sort(const Publication& p) {
  Sorted s;
  for (const TileMessage& t : p.tiles) ++(t.is_delta() ? s.delta : s.whole)[t.key()];
  return s;
}

void touch(GridMap& map, CellIndex c) {
  map.add_hit(c);
  map.commit_update();
}

TEST(TileSender, NewTilesGoWholeChangedOnesAsDeltasEveryFullEveryPublishesWhole) {
  GridMap map;
  TileSender sender({"m", 2}, TileEncoding::kMedZlib, {3, 1e9});
  const TileKey k = map.tile_of({5, 5});
  std::vector<char> kinds;
  for (int publish = 0; publish < 7; ++publish) {
    touch(map, {5, 5});
    const Publication p = sender.publish(map, publish, false, false, 1, "{}", 0);
    ASSERT_EQ(p.tiles.size(), 1u) << "publish " << publish;
    EXPECT_EQ(p.tiles[0].key(), k);
    EXPECT_EQ(p.tiles[0].version, map.find_tile(k)->version);
    kinds.push_back(p.tiles[0].is_delta() ? 'd' : 'w');
  }
  // New, then full_every - 1 = 2 deltas between whole copies.
  EXPECT_EQ(std::string(kinds.begin(), kinds.end()), "wddwddw");
}

TEST(TileSender, ADeltaIsAgainstTheVersionSentLast) {
  GridMap map;
  TileSender sender({}, TileEncoding::kMedZlib, {60, 1e9});
  touch(map, {1, 1});
  const std::uint64_t v1 = map.find_tile(map.tile_of({1, 1}))->version;
  (void)sender.publish(map, 0, false, false, 1, "{}", 0);
  touch(map, {2, 2});
  touch(map, {3, 3});  // two versions between publishes: one delta from v1
  const Publication p = sender.publish(map, 1, false, false, 2, "{}", 0);
  ASSERT_EQ(p.tiles.size(), 1u);
  ASSERT_TRUE(p.tiles[0].is_delta());
  EXPECT_EQ(*p.tiles[0].base_version, v1);
  EXPECT_EQ(p.tiles[0].version, v1 + 2);
}

TEST(TileSender, WholeWhenTheWholeCopyIsFullPeriodOld) {
  GridMap map;
  TileSender sender({}, TileEncoding::kMedZlib, {1000, 10.0});
  std::string kinds;
  for (double stamp : {0.0, 4.0, 9.9, 10.0, 15.0, 20.5}) {
    touch(map, {1, 1});
    kinds +=
        sender.publish(map, stamp, false, false, 1, "{}", 0).tiles.at(0).is_delta() ? 'd' : 'w';
  }
  EXPECT_EQ(kinds, "wddwdw");
}

TEST(TileSender, UnchangedTilesAreNotSent) {
  std::mt19937 gen(3);
  GridMap map;
  test::change_map(map, gen, 2000);
  TileSender sender({});
  EXPECT_EQ(sender.publish(map, 0, false, false, 1, "{}", 0).tiles.size(), map.tile_count());
  EXPECT_TRUE(sender.publish(map, 1, false, false, 1, "{}", 0).tiles.empty());
  map.mark_all_dirty();  // dirty, but no version is newer than what was sent
  EXPECT_TRUE(sender.publish(map, 2, false, false, 1, "{}", 0).tiles.empty());
}

TEST(TileSender, CompleteOrAJoiningReaderBringsEveryWholeCopyToItsNewestVersion) {
  for (const bool complete : {true, false}) {
    SCOPED_TRACE(complete ? "complete" : "reader joined");
    GridMap map;
    TileSender sender({}, TileEncoding::kMedZlib, {60, 1e9});
    touch(map, {1, 1});      // tile A
    touch(map, {200, 200});  // tile B
    (void)sender.publish(map, 0, false, false, 1, "{}", 0);
    touch(map, {1, 1});  // A changes: a delta, its whole copy is now behind
    EXPECT_EQ(sort(sender.publish(map, 1, false, false, 2, "{}", 0)).delta.size(), 1u);
    touch(map, {200, 200});  // B changes now
    const Publication p = sender.publish(map, 2, complete, !complete, 3, "{}", 0);
    const Sorted s = sort(p);
    EXPECT_EQ(p.joiner_refresh, !complete);
    EXPECT_EQ(p.meta.complete, complete);
    const TileKey a = map.tile_of({1, 1}), b = map.tile_of({200, 200});
    if (complete) {
      // Changed tiles go whole, and A's whole copy is refreshed.
      EXPECT_TRUE(s.delta.empty());
      EXPECT_EQ(s.whole.at(a), 1);
      EXPECT_EQ(s.whole.at(b), 1);
    } else {
      // B goes as a delta (live followers apply it), then B and A whole for the joiner.
      EXPECT_EQ(s.delta.at(b), 1);
      EXPECT_EQ(s.whole.at(a), 1);
      EXPECT_EQ(s.whole.at(b), 1);
      EXPECT_TRUE(p.tiles.front().is_delta());
    }
    // Nothing is behind any more: a second refresh sends nothing.
    EXPECT_TRUE(sender.publish(map, 3, false, true, 3, "{}", 0).tiles.empty());
  }
}

TEST(TileSender, RepublishAllSendsEveryTileWhole) {
  std::mt19937 gen(4);
  GridMap map;
  test::change_map(map, gen, 2000);
  TileSender sender({});
  (void)sender.publish(map, 0, false, false, 1, "{}", 0);
  sender.republish_all(map);
  const Publication p = sender.publish(map, 1, false, false, 1, "{}", 0);
  EXPECT_EQ(sort(p).whole.size(), map.tile_count());
  EXPECT_TRUE(sort(p).delta.empty());
}

TEST(TileSender, TheSummaryFollowsTheTilesAndDescribesTheMap) {
  std::mt19937 gen(5);
  GridMap map;
  test::change_map(map, gen, 500);
  TileSender sender({"fleet", 9});
  const Publication p = sender.publish(map, 0, false, false, 17, "{\"mu\":100}", 123);
  EXPECT_EQ(p.meta.map_id, "fleet");
  EXPECT_EQ(p.meta.epoch, 9u);
  EXPECT_EQ(p.meta.tile_count, map.tile_count());
  EXPECT_EQ(p.meta.map_version, map_version(map));
  EXPECT_EQ(p.meta.scans, 17u);
  EXPECT_EQ(p.meta.params, "{\"mu\":100}");
  EXPECT_EQ(p.meta.stamp_ns, 123u);
  for (const TileMessage& t : p.tiles) {
    EXPECT_EQ(t.map_id, "fleet");
    EXPECT_EQ(t.epoch, 9u);
    EXPECT_EQ(t.stamp_ns, 123u);
  }
}

}  // namespace
}  // namespace esfleet::mapshare
