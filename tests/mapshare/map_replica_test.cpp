// The follower's replica, without a network: a replica fed the leader's tile
// messages must hold counters equal to the leader's; anything malformed is rejected with a
// reason and leaves the replica untouched.

#include "esfleet/mapshare/map_replica.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <random>

#include "esfleet/core/tile_codec.hpp"
#include "test_maps.hpp"

namespace esfleet::mapshare {
namespace {

void send_all(const GridMap& leader, MapReplica& replica, const MapIdentity& id,
              TileEncoding enc = TileEncoding::kVarintZlib) {
  for (const TileKey k : leader.tile_keys()) {
    std::string error;
    ASSERT_EQ(replica.apply(whole_tile_message(leader, k, id, enc, 1), &error), Applied::kApplied)
        << error;
  }
}

TEST(MapReplica, RebuildsTheLeadersCountersExactly) {
  for (unsigned seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const GridMap leader = test::random_map(seed);
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
  GridMap leader = test::random_map(4);
  MapReplica replica;
  const MapIdentity id;
  const auto keys = leader.tile_keys();
  ASSERT_GT(keys.size(), 2u);
  EXPECT_EQ(replica.apply(meta_message(leader, id, true, 10, "{}", 1)), Applied::kApplied);
  EXPECT_FALSE(replica.complete());
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
    replica.apply(whole_tile_message(leader, keys[i], id, TileEncoding::kVarintZlib, 1));
  }
  EXPECT_FALSE(replica.complete());  // one tile missing
  replica.apply(whole_tile_message(leader, keys.back(), id, TileEncoding::kVarintZlib, 1));
  EXPECT_TRUE(replica.complete());

  // The leader changes a tile and says so: incomplete until the new version arrives.
  leader.add_hit({0, 0});
  leader.commit_update();
  replica.apply(meta_message(leader, id, true, 11, "{}", 2));
  EXPECT_FALSE(replica.complete());
  replica.apply(
      whole_tile_message(leader, leader.tile_of({0, 0}), id, TileEncoding::kVarintZlib, 2));
  EXPECT_TRUE(replica.complete());
  EXPECT_EQ(map_digest(replica.map()), map_digest(leader));
}

TEST(MapReplica, ArrivingWhileAFinalMapLacksTilesItAnnounced) {
  GridMap leader = test::random_map(4);
  const MapIdentity id;
  const auto keys = leader.tile_keys();
  ASSERT_GT(keys.size(), 2u);
  MapReplica replica;
  EXPECT_FALSE(replica.arriving());  // nothing announced
  // A live map (not final) is never "arriving": it always lags the leader a little.
  ASSERT_EQ(replica.apply(meta_message(leader, id, false, 10, "{}", 1)), Applied::kApplied);
  EXPECT_FALSE(replica.arriving());
  // Final: arriving until every announced tile is here.
  ASSERT_EQ(replica.apply(meta_message(leader, id, true, 11, "{}", 2)), Applied::kApplied);
  EXPECT_TRUE(replica.arriving());  // no tile yet
  for (std::size_t i = 0; i + 1 < keys.size(); ++i) {
    replica.apply(whole_tile_message(leader, keys[i], id, TileEncoding::kVarintZlib, 1));
    EXPECT_TRUE(replica.arriving()) << i + 1 << " of " << keys.size() << " tiles";
  }
  replica.apply(whole_tile_message(leader, keys.back(), id, TileEncoding::kVarintZlib, 1));
  EXPECT_FALSE(replica.arriving());
}

TEST(MapReplica, OlderOrEqualVersionsAreStale) {
  GridMap leader = test::random_map(5);
  const TileKey k = leader.tile_keys().front();
  const TileMessage v1 = whole_tile_message(leader, k, {}, TileEncoding::kVarintZlib, 1);
  leader.add_hit({k.tx * 64, k.ty * 64});
  leader.commit_update();
  const TileMessage v2 = whole_tile_message(leader, k, {}, TileEncoding::kVarintZlib, 2);
  MapReplica replica;
  EXPECT_EQ(replica.apply(v2), Applied::kApplied);
  EXPECT_EQ(replica.apply(v1), Applied::kStale);
  EXPECT_EQ(replica.apply(v2), Applied::kStale);
  EXPECT_EQ(replica.map().find_tile(k)->hit, leader.find_tile(k)->hit);
}

TEST(MapReplica, OtherMapsAndOlderEpochsAreIgnoredANewerEpochRestarts) {
  const GridMap a = test::random_map(6), b = test::random_map(7, 500);
  MapReplica replica("fleet");
  const TileKey ka = a.tile_keys().front();
  EXPECT_EQ(replica.apply(whole_tile_message(a, ka, {"other", 1}, TileEncoding::kRaw, 1)),
            Applied::kIgnored);
  EXPECT_FALSE(replica.has_map());
  send_all(a, replica, {"fleet", 2});
  EXPECT_EQ(replica.apply(
                whole_tile_message(b, b.tile_keys().front(), {"fleet", 1}, TileEncoding::kRaw, 1)),
            Applied::kIgnored);
  send_all(b, replica, {"fleet", 3});  // the leader restarted with a new map
  EXPECT_EQ(replica.epoch(), 3u);
  EXPECT_EQ(map_digest(replica.map()), map_digest(b));
}

TEST(MapReplica, MalformedTilesAreRejectedWithAReasonAndChangeNothing) {
  const GridMap leader = test::random_map(8);
  MapReplica replica;
  send_all(leader, replica, {});
  const std::string before = map_digest(replica.map());
  const TileMessage good =
      whole_tile_message(leader, leader.tile_keys().front(), {}, TileEncoding::kVarintZlib, 1);

  struct Case {
    const char* name;
    std::function<void(TileMessage&)> spoil;
    const char* expect;
  };
  const std::vector<Case> cases = {
      {"protocol", [](TileMessage& t) { t.protocol = 9; }, "protocol 9"},
      {"cells", [](TileMessage& t) { t.cells = 100; }, "cells 100"},
      {"tile edge", [](TileMessage& t) { t.tile_edge = 63; },
       "map.tile_edge must be a power of two in [8, 1024], got 63"},
      {"tile edge change", [](TileMessage& t) { t.tile_edge = 32; }, "differs"},
      {"cell size", [](TileMessage& t) { t.cell_size = std::nanf(""); }, "cell_size"},
      {"cell size change", [](TileMessage& t) { t.cell_size = 0.1f; }, "differs"},
      {"key", [](TileMessage& t) { t.tx = 5000000; }, "outside"},
      // Within +-1024 but 1000 tiles from the map: the directory would span them all.
      {"far key", [](TileMessage& t) { t.tx = t.tx >= 0 ? t.tx - 1000 : t.tx + 1000; },
       "would make the map span more than 512 tiles"},
      {"encoding", [](TileMessage& t) { t.encoding = 7; }, "unknown encoding 7"},
      {"payload", [](TileMessage& t) { t.payload.resize(t.payload.size() / 2); }, "zlib"},
      {"version 0", [](TileMessage& t) { t.version = 0; }, "version 0"},
      {"oversized", [](TileMessage& t) { t.payload.resize(16u << 20); },
       "payload of 16777216 bytes, more than the 41036 a tile of 4096 cells can need"},
      // A newer epoch would start a new map, but only once the tile is known to be sound.
      // A newer epoch starts a new map with the tile's layout: GridMap's own limits apply (a
      // cell size of 0.5 mm passed an older copy of them and then threw: fuzz_tile).
      {"newer epoch, cell size below a millimetre",
       [](TileMessage& t) {
         t.epoch = t.epoch + 1;
         t.cell_size = 0.0005f;
       },
       "map.cell_size must be in [0.001, 10] m"},
      {"newer epoch, bad payload",
       [](TileMessage& t) {
         t.epoch = t.epoch + 1;
         t.payload.resize(3);
       },
       "zlib"},
  };
  for (const Case& c : cases) {
    TileMessage bad = good;
    bad.version = good.version + 100;  // newer, so only validation can stop it
    c.spoil(bad);
    std::string error;
    EXPECT_EQ(replica.apply(bad, &error), Applied::kRejected) << c.name;
    EXPECT_NE(error.find(c.expect), std::string::npos) << c.name << ": " << error;
  }
  EXPECT_EQ(map_digest(replica.map()), before);
}

TEST(MapReplica, RebuildsTheLeadersMapFromAMixOfTilesAndDeltas) {
  std::mt19937 gen(11);
  GridMap leader = test::random_map(10);
  const MapIdentity id;
  MapReplica live;  // gets everything in order
  struct Sent {
    std::uint64_t version = 0, full_version = 0;
    std::vector<std::uint32_t> hit, err;
  };
  std::map<TileKey, Sent> sent;
  std::map<TileKey, TileMessage> last_full;  // what a transient-local KEEP_LAST 1 topic holds
  int fulls = 0, deltas = 0;
  const std::uint64_t full_every = 4;
  for (int step = 0; step < 40; ++step) {
    test::change_map(leader, gen, step % 7 == 0 ? 400 : 30);
    for (const TileKey k : leader.take_dirty()) {
      const Tile& tile = *leader.find_tile(k);
      auto [it, is_new] = sent.try_emplace(k);
      Sent& s = it->second;
      std::string error;
      if (is_new || tile.version - s.full_version >= full_every) {
        const TileMessage m = whole_tile_message(leader, k, id, TileEncoding::kMedZlib, step);
        ASSERT_EQ(live.apply(m, &error), Applied::kApplied) << error;
        last_full[k] = m;
        s.full_version = tile.version;
        ++fulls;
      } else {
        const TileMessage d = delta_tile_message(leader, k, s.version, s.hit, s.err, id,
                                                 TileEncoding::kMedZlib, step);
        EXPECT_EQ(d.base_version, s.version);
        EXPECT_EQ(d.version, tile.version);
        ASSERT_EQ(live.apply(d, &error), Applied::kApplied) << error;
        EXPECT_EQ(live.apply(d, &error), Applied::kStale);  // a duplicate
        ++deltas;
      }
      s.version = tile.version;
      s.hit = tile.hit;
      s.err = tile.err;
    }
    ASSERT_EQ(map_digest(live.map()), map_digest(leader)) << "step " << step;
  }
  EXPECT_GT(fulls, 0);
  EXPECT_GT(deltas, fulls);
  EXPECT_EQ(map_version(live.map()), map_version(leader));

  // A late joiner gets the newest whole tiles only; once the leader sends the whole tiles whose
  // copy is older than the newest version (as MapPublisher does when complete) it holds the map.
  MapReplica late;
  for (const auto& [k, m] : last_full) ASSERT_EQ(late.apply(m), Applied::kApplied);
  for (const auto& [k, s] : sent) {
    if (s.full_version < s.version) {
      EXPECT_EQ(late.apply(whole_tile_message(leader, k, id, TileEncoding::kMedZlib, 99)),
                Applied::kApplied);
      EXPECT_EQ(live.apply(whole_tile_message(leader, k, id, TileEncoding::kMedZlib, 99)),
                Applied::kStale);
    }
  }
  EXPECT_EQ(map_digest(late.map()), map_digest(leader));
}

TEST(MapReplica, ADeltaWithoutItsBaseNeedsBaseAndChangesNothing) {
  GridMap leader = test::random_map(12);
  const MapIdentity id;
  const TileKey k = leader.tile_keys().front();
  const Tile* tile = leader.find_tile(k);
  const std::uint64_t v1 = tile->version;
  const std::vector<std::uint32_t> hit1 = tile->hit, err1 = tile->err;
  const TileMessage full1 = whole_tile_message(leader, k, id, TileEncoding::kMedZlib, 1);
  leader.add_hit({k.tx * 64 + 3, k.ty * 64 + 5});
  leader.commit_update();
  const std::uint64_t v2 = tile->version;
  const std::vector<std::uint32_t> hit2 = tile->hit, err2 = tile->err;
  const TileMessage d12 =
      delta_tile_message(leader, k, v1, hit1, err1, id, TileEncoding::kMedZlib, 2);
  leader.add_err({k.tx * 64 + 7, k.ty * 64 + 1});
  leader.commit_update();
  const TileMessage d23 =
      delta_tile_message(leader, k, v2, hit2, err2, id, TileEncoding::kMedZlib, 3);
  EXPECT_LT(d23.payload.size(), 100u);  // mostly zero differences compress to little

  MapReplica replica;
  EXPECT_EQ(replica.apply(d12), Applied::kNeedsBase);  // no map at all yet
  EXPECT_FALSE(replica.has_map());
  send_all(test::random_map(13), replica, id);  // another map: no tile (300, ty)
  const std::string before = map_digest(replica.map());
  MapReplica fresh;
  EXPECT_EQ(fresh.apply(full1), Applied::kApplied);
  const std::string fresh_before = map_digest(fresh.map());
  EXPECT_EQ(fresh.apply(d23), Applied::kNeedsBase);  // holds v1, the delta needs v2
  EXPECT_EQ(map_digest(fresh.map()), fresh_before);
  EXPECT_EQ(fresh.map().find_tile(k)->version, v1);
  EXPECT_EQ(fresh.apply(d12), Applied::kApplied);
  EXPECT_EQ(fresh.apply(d23), Applied::kApplied);
  EXPECT_EQ(fresh.map().find_tile(k)->hit, tile->hit);
  EXPECT_EQ(fresh.map().find_tile(k)->err, tile->err);
  EXPECT_EQ(fresh.map().find_tile(k)->version, tile->version);
  EXPECT_EQ(fresh.apply(d12), Applied::kStale);
  // The replica holding other tiles but not the base of k: needs base, unchanged.
  TileMessage elsewhere = d12;
  elsewhere.tx = 300;  // within max_tile_span of the map (900 is refused as too far)
  EXPECT_EQ(replica.apply(elsewhere), Applied::kNeedsBase);
  EXPECT_EQ(map_digest(replica.map()), before);
}

TEST(MapReplica, MalformedDeltasAreRejectedWithAReasonAndChangeNothing) {
  GridMap leader = test::random_map(14);
  const MapIdentity id;
  MapReplica replica;
  send_all(leader, replica, id);
  const TileKey k = leader.tile_keys().front();
  const Tile* tile = leader.find_tile(k);
  const std::vector<std::uint32_t> hit = tile->hit, err = tile->err;
  const std::uint64_t base = tile->version;
  leader.add_hit({k.tx * 64, k.ty * 64});
  leader.commit_update();
  const TileMessage good =
      delta_tile_message(leader, k, base, hit, err, id, TileEncoding::kMedZlib, 1);
  const std::string before = map_digest(replica.map());

  struct Case {
    const char* name;
    std::function<void(TileMessage&)> spoil;
    const char* expect;
  };
  const std::vector<Case> cases = {
      {"protocol", [](TileMessage& d) { d.protocol = 9; }, "protocol 9"},
      {"cells", [](TileMessage& d) { d.cells = 100; }, "cells 100"},
      {"tile edge", [](TileMessage& d) { d.tile_edge = 63; },
       "map.tile_edge must be a power of two in [8, 1024], got 63"},
      {"tile edge change", [](TileMessage& d) { d.tile_edge = 32; }, "differs"},
      {"cell size", [](TileMessage& d) { d.cell_size = std::nanf(""); }, "cell_size"},
      {"key", [](TileMessage& d) { d.ty = -5000000; }, "outside"},
      {"base version", [](TileMessage& d) { d.base_version = d.version; }, "base_version"},
      {"encoding", [](TileMessage& d) { d.encoding = 7; }, "unknown encoding 7"},
      {"payload", [](TileMessage& d) { d.payload.resize(d.payload.size() / 2); }, "zlib"},
      {"oversized", [](TileMessage& d) { d.payload.assign(50000, 0); },
       "payload of 50000 bytes, more than the 41036"},
  };
  for (const Case& c : cases) {
    TileMessage bad = good;
    c.spoil(bad);
    std::string error;
    EXPECT_EQ(replica.apply(bad, &error), Applied::kRejected) << c.name;
    EXPECT_NE(error.find(c.expect), std::string::npos) << c.name << ": " << error;
  }
  EXPECT_EQ(map_digest(replica.map()), before);
  EXPECT_EQ(replica.apply(good), Applied::kApplied);
  EXPECT_EQ(map_digest(replica.map()), map_digest(leader));
}

TEST(MapReplica, MalformedSummariesAreRejectedWithAReasonAndChangeNothing) {
  const GridMap leader = test::random_map(15);
  const MapIdentity id{"map", 4};
  MapReplica replica;
  send_all(leader, replica, id);
  const MetaMessage good = meta_message(leader, id, false, 10, "{}", 1);
  ASSERT_EQ(replica.apply(good), Applied::kApplied);
  const std::string before = map_digest(replica.map());

  struct Case {
    const char* name;
    std::function<void(MetaMessage&)> spoil;
    const char* expect;
  };
  const std::vector<Case> cases = {
      {"protocol", [](MetaMessage& m) { m.protocol = 0; }, "protocol 0"},
      {"min > max", [](MetaMessage& m) { m.min_tx = m.max_tx + 1; }, "min_tx > max_tx"},
      {"bounds", [](MetaMessage& m) { m.min_ty = -2000000000; }, "reach outside +-1024"},
      {"tile count", [](MetaMessage& m) { m.tile_count = 4000000000u; }, "tile_count 4000000000"},
      {"tile edge change", [](MetaMessage& m) { m.tile_edge = 128; }, "differs"},
      {"cell size change", [](MetaMessage& m) { m.cell_size = 0.15f; }, "differs"},
      {"newer epoch, cell size below a millimetre",
       [](MetaMessage& m) {
         m.epoch = m.epoch + 1;
         m.cell_size = 0.0005f;
       },
       "map.cell_size must be in [0.001, 10] m"},
      {"newer epoch, tile edge 2048",
       [](MetaMessage& m) {
         m.epoch = m.epoch + 1;
         m.tile_edge = 2048;
       },
       "map.tile_edge must be a power of two in [8, 1024], got 2048"},
      {"newer epoch, absurd bounds",
       [](MetaMessage& m) {
         m.epoch = m.epoch + 1;
         m.max_tx = 2000000000;
       },
       "reach outside"},
  };
  for (const Case& c : cases) {
    MetaMessage bad = good;
    bad.map_version = good.map_version + 1000;  // newer, so only validation can stop it
    c.spoil(bad);
    std::string error;
    EXPECT_EQ(replica.apply(bad, &error), Applied::kRejected) << c.name;
    EXPECT_NE(error.find(c.expect), std::string::npos) << c.name << ": " << error;
    EXPECT_EQ(replica.epoch(), 4u) << c.name;
    EXPECT_EQ(replica.meta()->map_version, good.map_version) << c.name;
  }
  EXPECT_EQ(map_digest(replica.map()), before);
  // An older epoch is another (earlier) map: ignored, not an error.
  MetaMessage old = good;
  old.epoch = 3;
  EXPECT_EQ(replica.apply(old), Applied::kIgnored);
}

}  // namespace
}  // namespace esfleet::mapshare
