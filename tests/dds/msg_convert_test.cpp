// Conversion between our values and the wire types of idl/esfleet.idl, both directions
// (dds/include/esfleet/dds/to_msg.hpp, from_msg.hpp): map messages cross unchanged, scans and
// true poses that cannot be used are refused naming the field.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

#include "esfleet/dds/from_msg.hpp"
#include "esfleet/dds/to_msg.hpp"

namespace esfleet::dds {
namespace {

mapshare::TileMessage sample_tile() {
  mapshare::TileMessage t;
  t.map_id = "fleet";
  t.tx = -3;
  t.ty = 7;
  t.epoch = 5;
  t.version = 42;
  t.cell_size = 0.05f;
  t.tile_edge = 64;
  t.encoding = 2;
  t.cells = 4096;
  t.payload = {1, 2, 3, 250};
  t.stamp_ns = 1'700'000'000'123'456'789ull;
  return t;
}

void expect_same(const mapshare::TileMessage& a, const mapshare::TileMessage& b) {
  EXPECT_EQ(a.map_id, b.map_id);
  EXPECT_EQ(a.key(), b.key());
  EXPECT_EQ(a.protocol, b.protocol);
  EXPECT_EQ(a.epoch, b.epoch);
  EXPECT_EQ(a.version, b.version);
  EXPECT_EQ(a.base_version, b.base_version);
  EXPECT_EQ(a.cell_size, b.cell_size);
  EXPECT_EQ(a.tile_edge, b.tile_edge);
  EXPECT_EQ(a.encoding, b.encoding);
  EXPECT_EQ(a.cells, b.cells);
  EXPECT_EQ(a.payload, b.payload);
  EXPECT_EQ(a.stamp_ns, b.stamp_ns);
}

TEST(MsgConvert, TilesAndDeltasCrossTheWireUnchanged) {
  const mapshare::TileMessage whole = sample_tile();
  const msg::MapTile m = tile_to_msg(whole);
  EXPECT_EQ(m.protocol(), msg::kProtocolVersion);
  expect_same(tile_from_msg(msg::MapTile(m)), whole);

  mapshare::TileMessage delta = sample_tile();
  delta.base_version = 40;
  const msg::MapTileDelta d = delta_to_msg(delta);
  EXPECT_EQ(d.base_version(), 40u);
  expect_same(delta_from_msg(msg::MapTileDelta(d)), delta);
}

TEST(MsgConvert, SummaryCrossesTheWireAndLongParametersAreCut) {
  mapshare::MetaMessage meta;
  meta.map_id = "m";
  meta.epoch = 4;
  meta.cell_size = 0.05f;
  meta.tile_edge = 64;
  meta.min_tx = -2;
  meta.min_ty = -1;
  meta.max_tx = 3;
  meta.max_ty = 5;
  meta.tile_count = 12;
  meta.map_version = 999;
  meta.complete = true;
  meta.scans = 77;
  meta.params = "{\"mu\":100}";
  meta.stamp_ns = 5;
  const mapshare::MetaMessage back = meta_from_msg(meta_to_msg(meta));
  EXPECT_EQ(back.map_id, meta.map_id);
  EXPECT_EQ(back.protocol, meta.protocol);
  EXPECT_EQ(back.epoch, meta.epoch);
  EXPECT_EQ(back.cell_size, meta.cell_size);
  EXPECT_EQ(back.tile_edge, meta.tile_edge);
  EXPECT_EQ(back.min_tx, meta.min_tx);
  EXPECT_EQ(back.min_ty, meta.min_ty);
  EXPECT_EQ(back.max_tx, meta.max_tx);
  EXPECT_EQ(back.max_ty, meta.max_ty);
  EXPECT_EQ(back.tile_count, meta.tile_count);
  EXPECT_EQ(back.map_version, meta.map_version);
  EXPECT_EQ(back.complete, meta.complete);
  EXPECT_EQ(back.scans, meta.scans);
  EXPECT_EQ(back.params, meta.params);
  EXPECT_EQ(back.stamp_ns, meta.stamp_ns);
  meta.params = std::string(5000, 'x');
  EXPECT_EQ(meta_to_msg(meta).es_params().size(), 1024u);
}

TEST(MsgConvert, ScanRoundTripAndValidation) {
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

TEST(MsgConvert, TruthRoundTripAndValidation) {
  const TimedPose truth{1700000000.2, Pose2{-3.25, 12.5, 2.75}};
  const msg::TruthPose m = truth_to_msg("robot-3", truth);
  EXPECT_EQ(m.robot_id(), "robot-3");
  EXPECT_EQ(m.protocol(), msg::kProtocolVersion);
  const TimedPose back = truth_from_msg(m);
  EXPECT_EQ(back.stamp, truth.stamp);  // exact: evaluation pairs truth and scans by stamp
  EXPECT_EQ(back.pose, truth.pose);

  auto expect_rejected = [](const msg::TruthPose& bad, const std::string& field) {
    try {
      truth_from_msg(bad);
      ADD_FAILURE() << "accepted a message with a bad " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  msg::TruthPose bad = m;
  bad.protocol(static_cast<std::uint16_t>(msg::kProtocolVersion + 1));
  expect_rejected(bad, "protocol");
  bad = m;
  bad.robot_id("");
  expect_rejected(bad, "robot_id");
  bad = m;
  bad.stamp(std::nan(""));
  expect_rejected(bad, "stamp");
  bad = m;
  bad.y(std::numeric_limits<double>::infinity());
  expect_rejected(bad, "y");
  bad = m;
  bad.theta(std::nan(""));
  expect_rejected(bad, "theta");
}

}  // namespace
}  // namespace esfleet::dds
