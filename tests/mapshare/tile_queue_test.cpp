// The publisher's coalescing queue: one copy per tile, the newest, in the order tiles first
// came in; and, fed through a TileSender as the leader's publisher thread does, taken rarely
// (a slow link), it still brings a follower to the leader's exact map with fewer messages.

#include "esfleet/mapshare/tile_queue.hpp"

#include <gtest/gtest.h>

#include <random>

#include "esfleet/mapshare/map_replica.hpp"
#include "esfleet/mapshare/tile_sender.hpp"
#include "test_maps.hpp"

namespace esfleet::mapshare {
namespace {

void touch(GridMap& map, CellIndex c) {
  map.add_hit(c);
  map.commit_update();
}

TEST(TileQueue, KeepsTheNewestCopyOfEachTileInFirstComeOrder) {
  GridMap map;
  TileQueue q;
  const CellIndex a{5, 5}, b{-300, 40};
  touch(map, a);
  EXPECT_EQ(q.put_changed(map, 1), 1u);
  touch(map, b);
  touch(map, a);
  EXPECT_EQ(q.put_changed(map, 2), 2u);
  EXPECT_EQ(q.put_changed(map, 3), 0u);  // nothing changed since
  EXPECT_EQ(q.size(), 2u);
  EXPECT_EQ(q.coalesced(), 1u);
  EXPECT_EQ(q.high_water(), 2u);

  const std::vector<TileCopy> taken = q.take_all();
  EXPECT_TRUE(q.empty());
  ASSERT_EQ(taken.size(), 2u);
  const Tile& ta = *map.find_tile(map.tile_of(a));
  EXPECT_EQ(taken[0].key, ta.key);  // a came first, and kept its place when replaced
  EXPECT_EQ(taken[0].version, ta.version);
  EXPECT_EQ(taken[0].hit, ta.hit);
  EXPECT_EQ(taken[0].err, ta.err);
  EXPECT_EQ(taken[0].stamp_ns, 2u);
  EXPECT_EQ(taken[1].key, map.tile_of(b));
}

TEST(TileQueue, CopiesDoNotFollowTheMap) {
  GridMap map;
  TileQueue q;
  touch(map, {1, 1});
  q.put_changed(map, 0);
  const std::vector<std::uint32_t> hit = map.find_tile(map.tile_of({1, 1}))->hit;
  touch(map, {1, 1});  // the map moves on; the copy keeps the version handed over
  const std::vector<TileCopy> taken = q.take_all();
  ASSERT_EQ(taken.size(), 1u);
  EXPECT_EQ(taken[0].hit, hit);
  EXPECT_LT(taken[0].version, map.find_tile(map.tile_of({1, 1}))->version);
}

/// Hands the map over every step and sends only every `take_every` steps, as a publisher thread
/// behind a slow link; returns the messages sent. The follower must hold the leader's map after
/// every send.
std::size_t send_coalesced(unsigned seed, int take_every) {
  std::mt19937 gen(seed);
  GridMap leader;
  TileSender sender({"fleet", 1}, TileEncoding::kMedZlib, {5, 1e9});
  TileQueue q;
  MapReplica follower;
  std::size_t messages = 0;
  for (int step = 1; step <= 60; ++step) {
    test::change_map(leader, gen, step % 9 == 0 ? 300 : 20);
    q.put_changed(leader, static_cast<std::uint64_t>(step));
    if (step % take_every != 0) continue;
    const TileLayout layout = tile_layout(leader);
    for (const TileCopy& c : q.take_all()) {
      auto m = sender.send(layout, c.counters(), step, false, c.stamp_ns);
      if (!m) continue;
      ++messages;
      std::string error;
      EXPECT_EQ(follower.apply(*m, &error), Applied::kApplied) << error;
    }
    follower.apply(meta_message(leader, {"fleet", 1}, false, 0, "{}", 0));
    EXPECT_EQ(map_digest(follower.map()), map_digest(leader))
        << "seed " << seed << " step " << step;
  }
  return messages;
}

TEST(TileQueue, CoalescedVersionsMakeOneExactMessageAndTheFollowerEndsWithTheLeadersMap) {
  for (unsigned seed = 1; seed <= 3; ++seed) {
    const std::size_t every_step = send_coalesced(seed, 1);
    const std::size_t every_sixth = send_coalesced(seed, 6);
    EXPECT_LT(every_sixth * 2, every_step) << "seed " << seed;  // ~2.9x fewer here
  }
}

TEST(TileQueue, RefreshWholeSendsTheNewestVersionSentWhole) {
  GridMap leader;
  TileSender sender({"fleet", 1}, TileEncoding::kMedZlib, {60, 1e9});
  TileQueue q;
  const TileLayout layout = tile_layout(leader);
  touch(leader, {3, 3});
  q.put_changed(leader, 0);
  for (const TileCopy& c : q.take_all())
    ASSERT_TRUE(sender.send(layout, c.counters(), 0, false, 0));
  touch(leader, {3, 3});
  q.put_changed(leader, 0);
  for (const TileCopy& c : q.take_all()) {
    auto m = sender.send(layout, c.counters(), 1, false, 0);
    ASSERT_TRUE(m && m->is_delta());
  }
  std::vector<TileMessage> out;
  sender.refresh_whole(layout, 2, 0, out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_FALSE(out[0].is_delta());
  // A follower that joins now (whole copies only) holds the leader's map.
  MapReplica joiner;
  std::string error;
  ASSERT_EQ(joiner.apply(out[0], &error), Applied::kApplied) << error;
  EXPECT_EQ(map_digest(joiner.map()), map_digest(leader));
  out.clear();
  sender.refresh_whole(layout, 3, 0, out);
  EXPECT_TRUE(out.empty());  // the whole copy is the newest now
}

}  // namespace
}  // namespace esfleet::mapshare
