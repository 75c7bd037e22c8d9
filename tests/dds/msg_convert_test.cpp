// Conversion between our values and the wire types of idl/esfleet.idl, both directions
// (dds/include/esfleet/dds/to_msg.hpp, from_msg.hpp): map messages cross unchanged, scans and
// true poses that cannot be used are refused naming the field.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <esfleet/msg/esfleetPubSubTypes.h>

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

mapshare::TileMessage tile_with_payload(std::size_t bytes, std::uint64_t version,
                                        std::mt19937& rng) {
  mapshare::TileMessage t = sample_tile();
  t.version = version;
  t.payload.resize(bytes);
  for (auto& b : t.payload) b = static_cast<std::uint8_t>(rng());
  return t;
}

TEST(TileParts, TilesAndDeltasAreCutIntoPartsAndJoinedInAnyOrder) {
  for (const unsigned seed : {1u, 2u, 3u, 4u, 5u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937 rng(seed);
    const mapshare::TileMessage whole = tile_with_payload(2500, 42, rng);
    std::vector<msg::MapTile> parts = tile_to_msgs(whole);
    ASSERT_EQ(parts.size(), 3u);
    for (std::size_t i = 0; i < parts.size(); ++i) {
      EXPECT_EQ(parts[i].part(), i);
      EXPECT_EQ(parts[i].parts(), 3);
      EXPECT_EQ(parts[i].payload_size(), 2500u);
      EXPECT_EQ(parts[i].payload().size(), i < 2 ? kTilePartBytes : 2500 - 2 * kTilePartBytes);
    }
    std::shuffle(parts.begin(), parts.end(), rng);
    TilePartAssembler joiner;
    std::string error;
    EXPECT_FALSE(joiner.add(std::move(parts[0]), "w", &error));
    EXPECT_EQ(error, "");
    EXPECT_FALSE(joiner.add(std::move(parts[1]), "w", &error));
    EXPECT_EQ(joiner.pending_tiles(), 1u);
    const auto joined = joiner.add(std::move(parts[2]), "w", &error);
    ASSERT_TRUE(joined) << error;
    expect_same(*joined, whole);
    EXPECT_EQ(joiner.pending_bytes(), 0u);

    mapshare::TileMessage delta = tile_with_payload(1025, 43, rng);
    delta.base_version = 42;
    std::vector<msg::MapTileDelta> dparts = delta_to_msgs(delta);
    ASSERT_EQ(dparts.size(), 2u);
    EXPECT_EQ(dparts[1].base_version(), 42u);
    TilePartAssembler djoiner;
    EXPECT_FALSE(djoiner.add(std::move(dparts[1]), "w"));
    const auto djoined = djoiner.add(std::move(dparts[0]), "w");
    ASSERT_TRUE(djoined);
    expect_same(*djoined, delta);
  }
}

TEST(TileParts, SmallAndEmptyPayloadsTravelAsOnePart) {
  mapshare::TileMessage t = sample_tile();
  t.payload.assign(kTilePartBytes, 7);
  std::vector<msg::MapTile> parts = tile_to_msgs(t);
  ASSERT_EQ(parts.size(), 1u);
  TilePartAssembler joiner;
  const auto joined = joiner.add(std::move(parts[0]), "w");
  ASSERT_TRUE(joined);
  expect_same(*joined, t);
  t.payload.clear();
  EXPECT_EQ(tile_to_msgs(t).size(), 1u);
  EXPECT_THROW(tile_to_msgs(t, 0), std::invalid_argument);
}

TEST(TileParts, ANewerVersionReplacesTheOlderPartsAndLateOlderPartsAreDropped) {
  std::mt19937 rng(11);
  std::vector<msg::MapTile> v5 = tile_to_msgs(tile_with_payload(3000, 5, rng));
  const mapshare::TileMessage six = tile_with_payload(2000, 6, rng);
  std::vector<msg::MapTile> v6 = tile_to_msgs(six);
  TilePartAssembler joiner;
  std::string error;
  EXPECT_FALSE(joiner.add(std::move(v5[0]), "w", &error));
  EXPECT_FALSE(joiner.add(std::move(v6[1]), "w", &error));
  EXPECT_EQ(joiner.pending_bytes(), 2000 - kTilePartBytes);  // version 5's part was dropped
  const auto joined = joiner.add(std::move(v6[0]), "w", &error);
  ASSERT_TRUE(joined) << error;
  EXPECT_EQ(joined->version, 6u);
  // What a late joiner reads from KEEP_LAST 1: the third part of version 5 (version 6 has two).
  EXPECT_FALSE(joiner.add(std::move(v5[2]), "w", &error));
  EXPECT_EQ(error, "");
  EXPECT_EQ(joiner.pending_bytes(), 0u);
  // A one-part version 7 also makes version 6's parts stale.
  mapshare::TileMessage seven = tile_with_payload(10, 7, rng);
  std::vector<msg::MapTile> v7 = tile_to_msgs(seven);
  ASSERT_TRUE(joiner.add(std::move(v7[0]), "w"));
  std::vector<msg::MapTile> v6again = tile_to_msgs(six);
  EXPECT_FALSE(joiner.add(std::move(v6again[0]), "w", &error));
  EXPECT_EQ(error, "");
  EXPECT_EQ(joiner.pending_bytes(), 0u);
}

TEST(TileParts, AnotherWritersNewerVersionDoesNotDisturbTheJoining) {
  std::mt19937 rng(14);
  const mapshare::TileMessage leader = tile_with_payload(2000, 5, rng);
  std::vector<msg::MapTile> parts = tile_to_msgs(leader);
  TilePartAssembler joiner;
  EXPECT_FALSE(joiner.add(std::move(parts[0]), "leader"));
  // A rogue's bogus version 1000 of the same tile, in one part and in two.
  EXPECT_TRUE(joiner.add(std::move(tile_to_msgs(tile_with_payload(10, 1000, rng))[0]), "rogue"));
  EXPECT_FALSE(joiner.add(std::move(tile_to_msgs(tile_with_payload(1500, 1001, rng))[0]), "rogue"));
  const auto joined = joiner.add(std::move(parts[1]), "leader");
  ASSERT_TRUE(joined);
  expect_same(*joined, leader);
}

TEST(TileParts, InconsistentPartsAreRefusedNamingTheCause) {
  std::mt19937 rng(12);
  const mapshare::TileMessage t = tile_with_payload(2100, 9, rng);
  TilePartAssembler joiner;
  std::string error;
  std::vector<msg::MapTile> p = tile_to_msgs(t);
  p[0].part(3);
  EXPECT_FALSE(joiner.add(msg::MapTile(p[0]), "w", &error));
  EXPECT_EQ(error, "part 3 of 3");
  p[0].parts(0);
  EXPECT_FALSE(joiner.add(msg::MapTile(p[0]), "w", &error));
  EXPECT_EQ(error, "parts is 0");
  p = tile_to_msgs(t);
  p[1].payload_size(10);
  EXPECT_FALSE(joiner.add(msg::MapTile(p[1]), "w", &error));
  EXPECT_NE(error.find("more than the payload_size"), std::string::npos) << error;
  p = tile_to_msgs(t);
  EXPECT_FALSE(joiner.add(msg::MapTile(p[0]), "w", &error));
  p[1].tile_edge(32);
  EXPECT_FALSE(joiner.add(msg::MapTile(p[1]), "w", &error));
  EXPECT_EQ(error, "parts of version 9 disagree");
  p = tile_to_msgs(t);
  p[2].payload().pop_back();  // sizes that do not add up
  EXPECT_FALSE(joiner.add(msg::MapTile(p[1]), "w", &error));
  EXPECT_FALSE(joiner.add(msg::MapTile(p[2]), "w", &error));
  EXPECT_NE(error.find("payload_size 2100"), std::string::npos) << error;
  p = tile_to_msgs(t);
  p[0].payload_size(static_cast<std::uint32_t>(mapshare::kMaxTilePayloadBytes + 1));
  EXPECT_FALSE(joiner.add(msg::MapTile(p[0]), "w", &error));
  EXPECT_NE(error.find("any tile can need"), std::string::npos) << error;
  std::vector<msg::MapTile> one = tile_to_msgs(tile_with_payload(100, 10, rng));
  one[0].payload_size(99);
  EXPECT_FALSE(joiner.add(std::move(one[0]), "w", &error));
  EXPECT_NE(error.find("payload_size 99"), std::string::npos) << error;
}

TEST(TileParts, AHostilePeersHalfTilesAreBoundedInMemory) {
  TilePartAssembler joiner;
  std::string error;
  std::size_t refused = 0;
  // 70000 tiles that each claim 65535 parts and send one of 1000 bytes.
  for (int k = 0; k < 70000; ++k) {
    msg::MapTile m;
    m.map_id("x");
    m.tx(k);
    m.version(1);
    m.part(0);
    m.parts(65535);
    m.payload_size(static_cast<std::uint32_t>(mapshare::kMaxTilePayloadBytes));
    m.payload(std::vector<std::uint8_t>(1000, 1));
    if (!joiner.add(std::move(m), "rogue", &error) && !error.empty()) ++refused;
  }
  EXPECT_LE(joiner.pending_bytes(), TilePartAssembler::kMaxPendingBytes);
  EXPECT_LE(joiner.pending_tiles(), TilePartAssembler::kMaxTiles);
  EXPECT_GE(refused, 70000 - TilePartAssembler::kMaxTiles);
}

// Every sample esfleet sends on the map topics fits in one 1400-byte RTPS message, so Fast DDS
// never fragments it: at most 1284 bytes of serialized data (1400 - RTPS header 20 - INFO_DST 16
// - INFO_TS 12 - DATA_FRAG header 36 - heartbeat 32, Fast DDS 2.9.1 RTPSWriter.cpp:303-322).
TEST(TileParts, TheLargestSamplesFitInOneRtpsMessageOf1400Bytes) {
  constexpr std::uint32_t kMaxData = 1284;
  std::mt19937 rng(13);
  mapshare::TileMessage t = tile_with_payload(5 * kTilePartBytes, 1, rng);
  t.map_id = std::string(64, 'm');
  t.base_version = 0;
  msg::MapTilePubSubType tile_type;
  for (msg::MapTile& m : tile_to_msgs(t)) {
    const std::uint32_t size = tile_type.getSerializedSizeProvider(&m)();
    EXPECT_LE(size, kMaxData);
    EXPECT_GT(size, kTilePartBytes);
  }
  msg::MapTileDeltaPubSubType delta_type;
  for (msg::MapTileDelta& m : delta_to_msgs(t)) {
    EXPECT_LE(delta_type.getSerializedSizeProvider(&m)(), kMaxData);
  }
  mapshare::MetaMessage meta;
  meta.map_id = std::string(64, 'm');
  meta.params = std::string(2000, 'p');  // cut to 1024 on the wire
  msg::MapMeta mm = meta_to_msg(meta);
  msg::MapMetaPubSubType meta_type;
  EXPECT_LE(meta_type.getSerializedSizeProvider(&mm)(), kMaxData);
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
  // Every beam in one direction: refused, naming the field; one beam needs no increment.
  m = scan_to_msg("r1", 3, s);
  m.angle_increment(0.0f);
  try {
    scan_from_msg(m);
    ADD_FAILURE() << "accepted 3 beams with a zero angle_increment";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "laser scan message: angle_increment is zero for 3 beams");
  }
  m.ranges().resize(1);
  EXPECT_EQ(scan_from_msg(m).ranges.size(), 1u);
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

Contribution sample_contribution(std::size_t beams) {
  Contribution c;
  c.robot = "robot1";
  c.seq = 17;
  c.pose = Pose2{3.25, -7.5, 1.25};
  c.scan.stamp = 981.5;
  c.scan.angle_min = -1.5708f;
  c.scan.angle_increment = 3.14159f / static_cast<float>(beams - 1);
  c.scan.max_range = 50.0f;
  std::mt19937 rng(29);
  std::uniform_real_distribution<float> range(0.1f, 49.0f);
  for (std::size_t i = 0; i < beams; ++i) c.scan.ranges.push_back(range(rng));
  return c;
}

TEST(ContributionConvert, RoundTripInMillimetres) {
  Contribution c = sample_contribution(361);
  c.scan.ranges[0] = 50.0f;          // at max_range: no return
  c.scan.ranges[1] = 70.0f;          // beyond it
  c.scan.ranges[2] = std::nanf("");  // invalid: 0, skipped by the SLAM
  c.scan.ranges[3] = -1.0f;          // invalid
  c.scan.ranges[4] = 1.2344f;        // rounded to the millimetre
  const ContributionClaim claim{"fleet", 4, 0.9f, 0.75f};
  const msg::ContributedScan m = contribution_to_msg(c, claim);
  EXPECT_EQ(m.protocol(), msg::kProtocolVersion);
  EXPECT_EQ(m.ranges_mm()[0], msg::kNoReturnMm);
  EXPECT_EQ(m.ranges_mm()[1], msg::kNoReturnMm);
  EXPECT_EQ(m.ranges_mm()[2], 0);
  EXPECT_EQ(m.ranges_mm()[3], 0);
  EXPECT_EQ(m.ranges_mm()[4], 1234);

  const ReceivedContribution r = contribution_from_msg(m);
  EXPECT_EQ(r.contribution.robot, "robot1");
  EXPECT_EQ(r.contribution.seq, 17u);
  EXPECT_EQ(r.contribution.pose, c.pose);
  EXPECT_EQ(r.contribution.scan.stamp, c.scan.stamp);
  EXPECT_EQ(r.contribution.scan.angle_min, c.scan.angle_min);
  EXPECT_EQ(r.contribution.scan.angle_increment, c.scan.angle_increment);
  EXPECT_EQ(r.contribution.scan.max_range, 50.0f);
  EXPECT_FALSE(r.contribution.scan.odometry.has_value());
  EXPECT_EQ(r.claim.map_id, "fleet");
  EXPECT_EQ(r.claim.epoch, 4u);
  EXPECT_EQ(r.claim.agreement, 0.9f);
  EXPECT_EQ(r.claim.known, 0.75f);
  ASSERT_EQ(r.contribution.scan.ranges.size(), 361u);
  EXPECT_EQ(r.contribution.scan.ranges[0], 50.0f);
  EXPECT_EQ(r.contribution.scan.ranges[1], 50.0f);
  EXPECT_TRUE(r.contribution.scan.is_no_return(1));
  EXPECT_EQ(r.contribution.scan.ranges[2], 0.0f);
  EXPECT_FLOAT_EQ(r.contribution.scan.ranges[4], 1.234f);
  for (std::size_t i = 5; i < 361; ++i) {
    EXPECT_NEAR(r.contribution.scan.ranges[i], c.scan.ranges[i], 0.0005f) << i;
  }
}

TEST(ContributionConvert, RangesBeyond65MetresAreNoReturn) {
  EXPECT_EQ(range_to_mm(65.534f, 81.9f), 65534);
  EXPECT_EQ(range_to_mm(65.535f, 81.9f), msg::kNoReturnMm);
  EXPECT_EQ(range_to_mm(70.0f, 81.9f), msg::kNoReturnMm);
  EXPECT_EQ(range_to_mm(81.9f, 81.9f), msg::kNoReturnMm);
  EXPECT_EQ(range_to_mm(std::numeric_limits<float>::infinity(), 81.9f), msg::kNoReturnMm);
  EXPECT_EQ(range_to_mm(0.0f, 81.9f), 0);
}

TEST(ContributionConvert, MalformedFieldsAreRefusedNamingThem) {
  const msg::ContributedScan good =
      contribution_to_msg(sample_contribution(181), ContributionClaim{"fleet", 1, 0.9f, 0.8f});
  auto expect_rejected = [](const msg::ContributedScan& bad, const std::string& field) {
    try {
      contribution_from_msg(bad);
      ADD_FAILURE() << "accepted a contribution with a bad " << field;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  const double nan = std::nan("");
  const double inf = std::numeric_limits<double>::infinity();
  msg::ContributedScan bad = good;
  bad.robot_id("");
  expect_rejected(bad, "robot_id");
  bad = good;
  bad.map_id("");
  expect_rejected(bad, "map_id");
  bad = good;
  bad.stamp(nan);
  expect_rejected(bad, "stamp");
  bad = good;
  bad.x(nan);
  expect_rejected(bad, "x");
  bad = good;
  bad.y(-inf);
  expect_rejected(bad, "y");
  bad = good;
  bad.x(2e6);
  expect_rejected(bad, "x");
  bad = good;
  bad.theta(inf);
  expect_rejected(bad, "theta");
  bad = good;
  bad.agreement(std::nanf(""));
  expect_rejected(bad, "agreement");
  bad = good;
  bad.known(1.5f);
  expect_rejected(bad, "known");
  bad = good;
  bad.ranges_mm().clear();
  expect_rejected(bad, "ranges_mm");
  bad = good;
  bad.ranges_mm().resize(msg::kMaxScanBeams + 1, 1000);
  expect_rejected(bad, "ranges_mm");
  bad = good;
  bad.angle_min(std::nanf(""));
  expect_rejected(bad, "angle_min");
  bad = good;
  bad.angle_min(100.0f);
  expect_rejected(bad, "angle_min");
  bad = good;
  bad.angle_increment(0.0f);
  expect_rejected(bad, "angle_increment");
  bad = good;
  bad.angle_increment(std::numeric_limits<float>::infinity());
  expect_rejected(bad, "angle_increment");
  bad = good;
  bad.angle_increment(2.0f);
  expect_rejected(bad, "angle_increment");
  bad = good;
  bad.max_range(0.0f);
  expect_rejected(bad, "max_range");
  bad = good;
  bad.max_range(std::nanf(""));
  expect_rejected(bad, "max_range");
  EXPECT_NO_THROW(contribution_from_msg(good));

  Contribution too_many = sample_contribution(181);
  too_many.scan.ranges.resize(msg::kMaxScanBeams + 1, 1.0f);
  EXPECT_THROW(contribution_to_msg(too_many, ContributionClaim{"m", 1, 1.0f, 1.0f}),
               std::invalid_argument);
}

// A contributed scan of a 361-beam laser (and of 500 beams) fits in one 1400-byte RTPS message
// with the longest ids, like the map samples (TileParts above), so Fast DDS never fragments it.
TEST(ContributionConvert, ScansOf361And500BeamsFitInOneRtpsMessageOf1400Bytes) {
  constexpr std::uint32_t kMaxData = 1284;
  msg::ContributedScanPubSubType type;
  for (const std::size_t beams : {std::size_t{361}, std::size_t{500}}) {
    Contribution c = sample_contribution(beams);
    c.robot = std::string(64, 'r');
    msg::ContributedScan m =
        contribution_to_msg(c, ContributionClaim{std::string(64, 'm'), 1, 1.0f, 1.0f});
    const std::uint32_t size = type.getSerializedSizeProvider(&m)();
    EXPECT_LE(size, kMaxData) << beams << " beams";
    EXPECT_GT(size, 2 * beams) << beams << " beams";
  }
}

// Longer scans (a 1081-beam Hokuyo, a 811-beam SICK, 3000 beams) go as every k-th beam, the
// smallest k that fits one RTPS message: the same beams at the same angles, never fragmented.
TEST(ContributionConvert, LongScansAreSentAsEveryKthBeamAndStillFitOneRtpsMessage) {
  msg::ContributedScanPubSubType type;
  for (const std::size_t beams : {std::size_t{811}, std::size_t{1081}, std::size_t{3000}}) {
    for (const std::size_t id_length : {std::size_t{8}, std::size_t{64}}) {
      Contribution c = sample_contribution(beams);
      c.robot = std::string(id_length, 'r');
      msg::ContributedScan m =
          contribution_to_msg(c, ContributionClaim{std::string(id_length, 'm'), 1, 1.0f, 1.0f});
      const std::size_t size = type.getSerializedSizeProvider(&m)();
      EXPECT_LE(size, kMaxContributionData) << beams;
      const std::size_t sent = m.ranges_mm().size();
      const std::size_t step = (beams + sent - 1) / sent;
      ASSERT_GE(step, 2u) << beams;
      EXPECT_EQ(sent, (beams + step - 1) / step);
      // The smallest step: with one less, the ranges would not fit.
      const std::size_t fixed = size - 2 * sent;
      EXPECT_GT(fixed + 2 * ((beams + step - 2) / (step - 1)), kMaxContributionData) << beams;
      const Contribution back = contribution_from_msg(m).contribution;
      EXPECT_FLOAT_EQ(back.scan.angle_min, c.scan.angle_min);
      EXPECT_FLOAT_EQ(back.scan.angle_increment, c.scan.angle_increment * static_cast<float>(step));
      for (std::size_t j = 0; j < back.scan.ranges.size(); ++j) {
        EXPECT_NEAR(back.scan.ranges[j], c.scan.ranges[j * step], 0.0006) << beams << " beam " << j;
        EXPECT_NEAR(back.scan.angle(j), c.scan.angle(j * step), 1e-5) << beams << " beam " << j;
      }
    }
  }
}

TEST(ContributionConvert, StatusRoundTripAndValidation) {
  ContributionTally t;
  t.last_seq = 99;
  t.last_verdict = ContributionVerdict::kRefineMoved;
  t.accepted = 120;
  t.rejected = 3;
  t.rejected_in_row = 2;
  t.stamp_ns = 1700000000123456789ull;
  const msg::ContributionStatus m = contribution_status_to_msg("robot1", t);
  EXPECT_EQ(m.robot_id(), "robot1");
  EXPECT_EQ(m.protocol(), msg::kProtocolVersion);
  const ContributionTally back = contribution_status_from_msg(m);
  EXPECT_EQ(back.last_seq, 99u);
  EXPECT_EQ(back.last_verdict, ContributionVerdict::kRefineMoved);
  EXPECT_EQ(back.accepted, 120u);
  EXPECT_EQ(back.rejected, 3u);
  EXPECT_EQ(back.rejected_in_row, 2u);
  EXPECT_EQ(back.stamp_ns, t.stamp_ns);

  msg::ContributionStatus bad = m;
  bad.last_verdict(200);
  EXPECT_THROW(contribution_status_from_msg(bad), std::invalid_argument);
  bad = m;
  bad.robot_id("");
  EXPECT_THROW(contribution_status_from_msg(bad), std::invalid_argument);
}

}  // namespace
}  // namespace esfleet::dds
