// The view's tile frames (view/tile_frame.hpp): the cells' classes are map.png's, the frame
// round-trips, and a damaged frame is refused naming what is wrong.

#include "tile_frame.hpp"

#include <gtest/gtest.h>

#include <random>

#include "esfleet/core/ros_map_format.hpp"

namespace esfleet::view {
namespace {

TEST(TileFrame, ClassesFollowRosCellValue) {
  GridMap map;
  const CellIndex wall{3, 5}, free_cell{10, 2}, single_hit{20, 20};
  map.add_hit(wall);
  map.add_hit(wall);
  for (int i = 0; i < 5; ++i) map.add_err(free_cell);
  map.add_hit(single_hit);  // one stray return: unknown, as in map.png
  const Tile* t = map.find_tile(map.tile_of(wall));
  ASSERT_NE(t, nullptr);
  const int e = map.tile_edge();
  const auto classes = tile_classes(*t, e);
  ASSERT_EQ(classes.size(), static_cast<std::size_t>(e * e));
  EXPECT_EQ(classes[5 * e + 3], kCellOccupied);
  EXPECT_EQ(classes[2 * e + 10], kCellFree);
  EXPECT_EQ(classes[20 * e + 20], kCellUnknown);
  EXPECT_EQ(classes[0], kCellUnknown);
  std::size_t known = 0;
  for (auto c : classes) known += c != kCellUnknown;
  EXPECT_EQ(known, 2u);
}

TEST(TileFrame, RoundTripsCompressedAndRaw) {
  std::mt19937 rng(7);
  std::vector<std::uint8_t> classes(64 * 64);
  for (auto& c : classes) c = static_cast<std::uint8_t>(rng() % 3);
  for (bool compressed : {true, false}) {
    TileFrameHeader h;
    h.epoch = 1796285281;
    h.tx = -4;
    h.ty = 13;
    h.version = 0x1'0000'0002ull;
    h.stamp_ns = 1'796'285'281'123'456'789ull;
    h.tile_edge = 64;
    h.compressed = compressed;
    const std::string frame = encode_tile_frame(h, classes);
    EXPECT_EQ(frame[0], 'T');
    if (!compressed) {
      EXPECT_EQ(frame.size(), kTileFrameHeaderBytes + classes.size());
    }
    std::string error;
    const auto d = decode_tile_frame(frame, &error);
    ASSERT_TRUE(d) << error;
    EXPECT_EQ(d->header.epoch, h.epoch);
    EXPECT_EQ(d->header.tx, h.tx);
    EXPECT_EQ(d->header.ty, h.ty);
    EXPECT_EQ(d->header.version, h.version);
    EXPECT_EQ(d->header.stamp_ns, h.stamp_ns);
    EXPECT_EQ(d->header.tile_edge, 64u);
    EXPECT_EQ(d->header.compressed, compressed);
    EXPECT_EQ(d->classes, classes);
  }
}

TEST(TileFrame, MostlyUnknownTileCompressesWell) {
  std::vector<std::uint8_t> classes(64 * 64, kCellUnknown);
  for (int i = 0; i < 64; ++i) classes[i * 64 + i] = kCellOccupied;
  TileFrameHeader h;
  h.tile_edge = 64;
  const std::string frame = encode_tile_frame(h, classes);
  EXPECT_LT(frame.size(), 400u);  // 4096 cells, one diagonal wall
}

TEST(TileFrame, EncodeRefusesWrongSizes) {
  TileFrameHeader h;
  h.tile_edge = 64;
  EXPECT_THROW(encode_tile_frame(h, std::vector<std::uint8_t>(100)), std::invalid_argument);
  h.tile_edge = 0;
  EXPECT_THROW(encode_tile_frame(h, {}), std::invalid_argument);
}

TEST(TileFrame, DecodeRefusesDamagedFrames) {
  TileFrameHeader h;
  h.tile_edge = 8;
  const std::string good = encode_tile_frame(h, std::vector<std::uint8_t>(64, kCellFree));
  const auto refused = [](const std::string& f, const std::string& words) {
    std::string error;
    EXPECT_FALSE(decode_tile_frame(f, &error));
    EXPECT_NE(error.find(words), std::string::npos) << error;
  };
  refused(good.substr(0, 10), "shorter than the header");
  std::string f = good;
  f[0] = 'X';
  refused(f, "type");
  f = good;
  f[1] = 9;
  refused(f, "layout version");
  f = good;
  f[2] = 7;
  refused(f, "encoding");
  refused(good + "xx", "payload size");
  f = good;
  f[kTileFrameHeaderBytes + 3] ^= 0x55;  // zlib stream damaged
  refused(f, "zlib");
  h.compressed = false;
  std::string raw = encode_tile_frame(h, std::vector<std::uint8_t>(64, kCellFree));
  raw[kTileFrameHeaderBytes + 5] = 3;
  refused(raw, "class 3");
}

}  // namespace
}  // namespace esfleet::view
