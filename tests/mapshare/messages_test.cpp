// Building the protocol's messages from a map: a delta needs a sound base, the summary describes
// the map.

#include "esfleet/mapshare/messages.hpp"

#include <gtest/gtest.h>

#include <random>
#include <stdexcept>
#include <vector>
#include "test_maps.hpp"

namespace esfleet::mapshare {
namespace {

TEST(MapMessages, ADeltaNeedsAnOlderBaseOfTheTilesSize) {
  const GridMap leader = test::random_map(15);
  const TileKey k = leader.tile_keys().front();
  const Tile& t = *leader.find_tile(k);
  EXPECT_THROW(
      delta_tile_message(leader, k, t.version, t.hit, t.err, {}, TileEncoding::kMedZlib, 1),
      std::invalid_argument);
  const std::vector<std::uint32_t> small(10);
  EXPECT_THROW(delta_tile_message(leader, k, 0, small, small, {}, TileEncoding::kMedZlib, 1),
               std::invalid_argument);
  EXPECT_THROW(whole_tile_message(leader, TileKey{900, 900}, {}, TileEncoding::kMedZlib, 1),
               std::invalid_argument);
}

TEST(MapMessages, WholeTileCarriesTheTileAndItsIdentity) {
  const GridMap leader = test::random_map(3);
  const TileKey k = leader.tile_keys().back();
  const TileMessage m = whole_tile_message(leader, k, {"m", 4}, TileEncoding::kVarintZlib, 77);
  EXPECT_FALSE(m.is_delta());
  EXPECT_EQ(m.map_id, "m");
  EXPECT_EQ(m.epoch, 4u);
  EXPECT_EQ(m.key(), k);
  EXPECT_EQ(m.version, leader.find_tile(k)->version);
  EXPECT_EQ(m.cells, leader.cells_per_tile());
  EXPECT_EQ(m.tile_edge, leader.tile_edge());
  EXPECT_EQ(m.stamp_ns, 77u);
  EXPECT_EQ(m.protocol, kProtocolVersion);
  std::vector<std::uint32_t> hit, err;
  decode_tile(static_cast<TileEncoding>(m.encoding), m.payload, m.cells, hit, err);
  EXPECT_EQ(hit, leader.find_tile(k)->hit);
  EXPECT_EQ(err, leader.find_tile(k)->err);
}

TEST(MapMessages, MetaDescribesTheMap) {
  const GridMap leader = test::random_map(9);
  const MetaMessage m = meta_message(leader, {"m", 4}, false, 77, "{\"mu\":100}", 5);
  EXPECT_EQ(m.map_id, "m");
  EXPECT_EQ(m.epoch, 4u);
  EXPECT_EQ(m.tile_count, leader.tile_count());
  EXPECT_EQ(m.map_version, map_version(leader));
  EXPECT_EQ(m.scans, 77u);
  EXPECT_EQ(m.params, "{\"mu\":100}");
  EXPECT_FALSE(m.complete);
  for (const TileKey k : leader.tile_keys()) {
    EXPECT_GE(k.tx, m.min_tx);
    EXPECT_LE(k.tx, m.max_tx);
    EXPECT_GE(k.ty, m.min_ty);
    EXPECT_LE(k.ty, m.max_ty);
  }
}

TEST(MapMessages, PayloadBoundIsZlibsBoundOfTheLongestStream) {
  EXPECT_EQ(max_payload_bytes(4096), 41036u);  // 40960 + 10 + 2 + 0 + 64
  EXPECT_EQ(kMaxTilePayloadBytes, max_payload_bytes(kMaxTileCells));
  EXPECT_GE(max_payload_bytes(4096), 8u * 4096);  // a raw tile fits
}

}  // namespace
}  // namespace esfleet::mapshare
