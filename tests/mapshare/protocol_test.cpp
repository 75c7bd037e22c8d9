// The map-sharing protocol end to end without a network: the leader's TileSender feeds
// followers' MapReplicas directly, as DDS would deliver its messages (or fail to). Whatever is
// lost, duplicated or reordered, a follower never holds counters the leader never had, and the
// protocol brings it to the leader's exact map.

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>

#include "esfleet/core/tile_codec.hpp"
#include "esfleet/mapshare/map_replica.hpp"
#include "esfleet/mapshare/publish_journal.hpp"
#include "esfleet/mapshare/tile_sender.hpp"
#include "test_maps.hpp"

namespace esfleet::mapshare {
namespace {

/// Applies every message of `p` in order; returns how many tiles were applied.
int deliver(const Publication& p, MapReplica& r, ReceiveStats* stats = nullptr) {
  int applied = 0;
  for (const TileMessage& t : p.tiles) {
    std::string error;
    const Applied a = r.apply(t, &error);
    EXPECT_NE(a, Applied::kRejected) << error;
    if (stats != nullptr) stats->count_tile(t.is_delta(), a);
    applied += a == Applied::kApplied ? 1 : 0;
  }
  EXPECT_NE(r.apply(p.meta), Applied::kRejected);
  return applied;
}

/// The whole copies a transient-local, keep-last-1 tile topic holds: the newest per key.
struct WholeCopies {
  std::map<TileKey, TileMessage> newest;
  void keep(const Publication& p) {
    for (const TileMessage& t : p.tiles) {
      if (!t.is_delta()) newest[t.key()] = t;
    }
  }
};

/// Every tile of `r` is a version the leader had: equal counters where the versions are equal.
void expect_no_foreign_counters(
    const MapReplica& r,
    const std::map<std::pair<TileKey, std::uint64_t>, std::uint64_t>& history) {
  if (!r.has_map()) return;
  for (const TileKey k : r.map().tile_keys()) {
    const Tile& t = *r.map().find_tile(k);
    const auto it = history.find({k, t.version});
    ASSERT_NE(it, history.end()) << "tile (" << k.tx << ", " << k.ty << ") v" << t.version;
    EXPECT_EQ(tile_digest(t.hit, t.err), it->second);
  }
}

class Protocol : public ::testing::TestWithParam<unsigned> {};

TEST_P(Protocol, FollowersInOrderLateOrLossyEndWithTheLeadersMap) {
  const unsigned seed = GetParam();
  std::mt19937 gen(seed);
  GridMap leader;
  TileSender sender({"fleet", 3}, TileEncoding::kMedZlib, {4, 1e9});
  MapReplica live, lossy;
  ReceiveStats live_stats, lossy_stats;
  WholeCopies topic;
  std::map<std::pair<TileKey, std::uint64_t>, std::uint64_t> history;  // (key, version) -> digest
  std::bernoulli_distribution lose(0.2);
  for (int step = 0; step < 40; ++step) {
    test::change_map(leader, gen, step % 7 == 0 ? 400 : 30);
    for (const TileKey k : leader.tile_keys()) {
      const Tile& t = *leader.find_tile(k);
      history[{k, t.version}] = tile_digest(t.hit, t.err);
    }
    const Publication p = sender.publish(leader, step, false, false, step, "{}", step);
    topic.keep(p);
    deliver(p, live, &live_stats);
    ASSERT_EQ(map_digest(live.map()), map_digest(leader)) << "seed " << seed << " step " << step;
    // The lossy follower misses a fifth of the deltas (a volatile topic without repair).
    Publication some = p;
    std::erase_if(some.tiles, [&](const TileMessage& t) { return t.is_delta() && lose(gen); });
    deliver(some, lossy, &lossy_stats);
    expect_no_foreign_counters(lossy, history);
  }
  EXPECT_GT(live_stats.deltas_applied, live_stats.tiles_applied);  // deltas did carry the map
  EXPECT_EQ(live_stats.deltas_needs_base, 0u);
  EXPECT_GT(lossy_stats.deltas_needs_base, 0u) << "seed " << seed;  // losses broke chains
  ASSERT_NE(map_digest(lossy.map()), map_digest(leader)) << "seed " << seed;

  // A late joiner: the newest whole copies only, which lag behind the deltas since.
  MapReplica late;
  for (const auto& [k, t] : topic.newest) ASSERT_EQ(late.apply(t), Applied::kApplied);
  ASSERT_NE(map_digest(late.map()), map_digest(leader)) << "seed " << seed;
  // The next publish notices the new reader and refreshes every whole copy that is behind:
  // the joiner, and the lossy follower too, then hold the leader's map.
  const Publication refresh = sender.publish(leader, 40, false, true, 40, "{}", 40);
  EXPECT_TRUE(refresh.joiner_refresh);
  for (MapReplica* r : {&live, &late, &lossy}) {
    deliver(refresh, *r);
    EXPECT_EQ(map_digest(r->map()), map_digest(leader));
  }

  // More changes and losses, then the leader's input ends: its complete map heals the lossy
  // follower, and both say complete.
  for (int step = 41; step < 50; ++step) {
    test::change_map(leader, gen, 30);
    Publication p = sender.publish(leader, step, false, false, step, "{}", step);
    deliver(p, live);
    std::erase_if(p.tiles, [&](const TileMessage& t) { return t.is_delta() && lose(gen); });
    deliver(p, lossy);
  }
  EXPECT_FALSE(lossy.complete());
  const Publication last = sender.publish(leader, 50, true, false, 50, "{}", 50);
  for (MapReplica* r : {&live, &lossy}) {
    deliver(last, *r);
    EXPECT_TRUE(r->complete());
    EXPECT_EQ(map_digest(r->map()), map_digest(leader));
  }
}

INSTANTIATE_TEST_SUITE_P(Seeds, Protocol, ::testing::Values(1u, 2u, 3u));

TEST(Protocol, DuplicatesAndOutOfOrderMessagesNeverTakeATileBack) {
  std::mt19937 gen(7);
  GridMap leader;
  TileSender sender({}, TileEncoding::kMedZlib, {3, 1e9});
  std::vector<Publication> sent;
  for (int step = 0; step < 12; ++step) {
    test::change_map(leader, gen, 60);
    sent.push_back(sender.publish(leader, step, false, false, step, "{}", step));
  }
  MapReplica replica;
  ReceiveStats stats;
  // Newest first, then everything again in order: older versions are stale, deltas whose base
  // is gone wait for a whole tile; nothing is rejected and no tile's version ever goes down.
  std::map<TileKey, std::uint64_t> held;
  auto deliver_checked = [&](const Publication& p) {
    deliver(p, replica, &stats);
    for (const TileKey k : replica.map().tile_keys()) {
      const std::uint64_t v = replica.map().find_tile(k)->version;
      EXPECT_GE(v, held[k]) << "tile (" << k.tx << ", " << k.ty << ") went back";
      EXPECT_LE(v, leader.find_tile(k)->version);
      held[k] = v;
    }
  };
  for (auto it = sent.rbegin(); it != sent.rend(); ++it) deliver_checked(*it);
  for (const Publication& p : sent) deliver_checked(p);
  EXPECT_GT(stats.tiles_stale, 0u);
  EXPECT_GT(stats.deltas_stale + stats.deltas_needs_base, 0u);
  EXPECT_EQ(stats.tiles_rejected + stats.deltas_rejected, 0u);
  // The newest summary stays: an older one is stale.
  EXPECT_EQ(replica.meta()->map_version, map_version(leader));
  EXPECT_EQ(replica.apply(sent.front().meta), Applied::kStale);
}

TEST(Protocol, AResumedLeaderSupersedesEverythingTheDeadOnePublished) {
  std::mt19937 gen(9);
  GridMap leader;
  TileSender sender({"fleet", 5});
  PublishJournal journal;  // persisted before every publish that needs it
  MapReplica follower;
  std::optional<GridMap> checkpoint;
  PublishJournal persisted;
  for (int step = 0; step < 30; ++step) {
    // The map grows to new tiles after the checkpoint too.
    test::change_map(leader, gen, 80);
    if (step == 20) leader.add_hit({900, 900});
    leader.commit_update();
    if (journal.reserve(leader)) persisted = journal;
    deliver(sender.publish(leader, step, false, false, step, "{}", step), follower);
    if (step == 12) checkpoint = test::copy_of(leader);
  }
  // The leader dies; the follower holds tiles newer than the checkpoint, and one it never had.
  ASSERT_EQ(map_digest(follower.map()), map_digest(leader));
  GridMap resumed = test::copy_of(*checkpoint);
  ASSERT_LT(resumed.tile_count(), leader.tile_count());
  const Superseded s = supersede(resumed, persisted);
  EXPECT_GT(s.tiles_added_empty, 0u);
  EXPECT_GT(s.new_version, map_version(follower.map()) / follower.map().tile_count());
  for (const TileKey k : follower.map().tile_keys()) {
    ASSERT_NE(resumed.find_tile(k), nullptr);
    EXPECT_GT(resumed.find_tile(k)->version, follower.map().find_tile(k)->version);
  }
  EXPECT_GT(persisted.version_ceiling, s.new_version);
  // The resumed leader (same map id and epoch) republishes all: the follower takes its map.
  TileSender again({"fleet", 5});
  again.republish_all(resumed);
  ReceiveStats stats;
  deliver(again.publish(resumed, 31, false, false, 31, "{}", 31), follower, &stats);
  EXPECT_EQ(stats.tiles_applied, resumed.tile_count());
  EXPECT_EQ(map_digest(follower.map()), map_digest(resumed));
}

}  // namespace
}  // namespace esfleet::mapshare
