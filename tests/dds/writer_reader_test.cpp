// Tests of the typed writers and readers (esfleet/dds/writer.hpp, reader.hpp) between two Nodes
// of one process over shared memory: every topic round-trips field by field, counters agree,
// more tiles than Fast DDS's default instance limit arrive, wrong-protocol samples are refused,
// samples longer than the bounded types (protocol 3) are not written, endpoints survive their
// Node, the contributed-scan topics reach the leader from a robot's partition and the answer
// only that robot. Each test uses its own domain id (110-119; 153 the contributed scans).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "dds_test_support.hpp"
#include "esfleet/dds/from_msg.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/reader.hpp"
#include "esfleet/dds/to_msg.hpp"
#include "esfleet/dds/writer.hpp"

namespace {

using namespace esfleet::dds;  // NOLINT: test brevity
namespace msg = esfleet::msg;
using std::chrono::milliseconds;

const std::string& kShm = esfleet::test::kShmProfile;

using esfleet::test::wait_until;

std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

/// Thread-safe store of what a reader's callback received.
template <class Msg>
struct Inbox {
  std::mutex mutex;
  std::vector<Msg> samples;
  std::vector<SampleMeta> metas;
  typename Reader<Msg>::Callback callback() {
    return [this](const Msg& m, const SampleMeta& meta) {
      std::lock_guard lock(mutex);
      samples.push_back(m);
      metas.push_back(meta);
    };
  }
};

msg::MapTile tile(int tx, int ty, std::uint64_t version) {
  msg::MapTile t;
  t.map_id("test_map");
  t.tx(tx);
  t.ty(ty);
  t.protocol(kProtocolVersion);
  t.epoch(7);
  t.version(version);
  t.cell_size(0.05f);
  t.tile_edge(64);
  t.encoding(msg::kEncodingVarintZlib);
  t.cells(4096);
  t.payload(std::vector<std::uint8_t>{1, 2, 3, static_cast<std::uint8_t>(version)});
  t.leader_stamp_ns(123456789);
  return t;
}

TEST(WriterReaderTest, AllFourTopicsRoundTripFieldByField) {
  Node leader({110, kShm, "leader"});
  Node follower({110, kShm, "follower"});
  Inbox<msg::MapTile> tiles;
  Inbox<msg::MapMeta> metas;
  Inbox<msg::RobotPose> poses;
  Inbox<msg::LaserScanMsg> scans;
  TileReader tile_reader(follower, tiles.callback());
  MetaReader meta_reader(follower, metas.callback());
  PoseReader pose_reader(leader, poses.callback());
  ScanReader scan_reader(leader, scans.callback());
  TileWriter tile_writer(leader);
  MetaWriter meta_writer(leader);
  PoseWriter pose_writer(follower);
  ScanWriter scan_writer(follower);
  EXPECT_EQ(tile_writer.topic_name(), "esfleet/map/tiles");
  EXPECT_EQ(meta_reader.topic_name(), "esfleet/map/meta");
  EXPECT_EQ(pose_writer.topic_name(), "esfleet/robots/pose");
  EXPECT_EQ(scan_reader.topic_name(), "esfleet/robots/scan");
  // Pose and scan are volatile: wait for the readers before writing.
  ASSERT_TRUE(pose_writer.wait_for_matched(1, milliseconds(5000)));
  ASSERT_TRUE(scan_writer.wait_for_matched(1, milliseconds(5000)));
  ASSERT_TRUE(tile_reader.wait_for_matched(1, milliseconds(5000)));
  // Discovery is not symmetric in time: the writer may see the reader a little later.
  ASSERT_TRUE(tile_writer.wait_for_matched(1, milliseconds(5000)));
  ASSERT_TRUE(meta_reader.wait_for_matched(1, milliseconds(5000)));
  ASSERT_TRUE(meta_writer.wait_for_matched(1, milliseconds(5000)));
  EXPECT_EQ(tile_writer.matched_readers(), 1);
  EXPECT_EQ(meta_reader.matched_writers(), 1);

  const std::int64_t before = now_ns();
  ASSERT_TRUE(tile_writer.write(tile(-3, 4, 9)));

  msg::MapMeta meta;
  meta.map_id("test_map");
  meta.protocol(kProtocolVersion);
  meta.epoch(7);
  meta.cell_size(0.05f);
  meta.tile_edge(64);
  meta.min_tx(-3);
  meta.min_ty(-1);
  meta.max_tx(5);
  meta.max_ty(4);
  meta.tile_count(42);
  meta.map_version(1234);
  meta.complete(true);
  meta.scans(910);
  meta.es_params(R"({"mu":1,"lambda":8})");
  meta.stamp_ns(99);
  ASSERT_TRUE(meta_writer.write(meta));

  msg::RobotPose pose;
  pose.robot_id("robot_2");
  pose.protocol(kProtocolVersion);
  pose.stamp(12.5);
  pose.x(1.25);
  pose.y(-2.5);
  pose.theta(0.75);
  pose.fitness(0.875f);
  pose.status(msg::kStatusTracking);
  ASSERT_TRUE(pose_writer.write(pose));

  msg::LaserScanMsg scan;
  scan.robot_id("robot_2");
  scan.protocol(kProtocolVersion);
  scan.seq(17);
  scan.stamp(12.5);
  scan.angle_min(-1.5f);
  scan.angle_increment(0.0175f);
  scan.max_range(30.0f);
  scan.ranges(std::vector<float>(181, 4.5f));
  scan.has_odometry(true);
  scan.odom_x(1.0);
  scan.odom_y(2.0);
  scan.odom_theta(3.0);
  ASSERT_TRUE(scan_writer.write(scan));

  ASSERT_TRUE(wait_until([&] {
    return tile_reader.samples_received() == 1 && meta_reader.samples_received() == 1 &&
           pose_reader.samples_received() == 1 && scan_reader.samples_received() == 1;
  }));
  std::lock_guard l1(tiles.mutex), l2(metas.mutex), l3(poses.mutex), l4(scans.mutex);
  EXPECT_EQ(tiles.samples.at(0), tile(-3, 4, 9));
  EXPECT_EQ(metas.samples.at(0), meta);
  EXPECT_EQ(poses.samples.at(0), pose);
  EXPECT_EQ(scans.samples.at(0), scan);

  // Byte counters: the same CDR size on both sides.
  EXPECT_EQ(tile_writer.bytes_written(), tile_reader.bytes_received());
  EXPECT_EQ(meta_writer.bytes_written(), meta_reader.bytes_received());
  EXPECT_EQ(pose_writer.bytes_written(), pose_reader.bytes_received());
  EXPECT_EQ(scan_writer.bytes_written(), scan_reader.bytes_received());
  // 181 floats + header fields: at least the ranges.
  EXPECT_GT(scan_writer.bytes_written(), 181u * 4u);
  std::cout << "[ measured ] CDR bytes per sample: tile(4-byte payload)="
            << tile_writer.bytes_written() << " meta=" << meta_writer.bytes_written()
            << " pose=" << pose_writer.bytes_written()
            << " scan(181 ranges)=" << scan_writer.bytes_written() << "\n";

  // Sample metadata: the writer's GUID carries its node's prefix; timestamps are wall clock.
  const SampleMeta& m = tiles.metas.at(0);
  EXPECT_EQ(m.writer_guid.rfind(leader.guid_prefix(), 0), 0u)
      << m.writer_guid << " vs " << leader.guid_prefix();
  EXPECT_EQ(poses.metas.at(0).writer_guid.rfind(follower.guid_prefix(), 0), 0u);
  EXPECT_GE(m.source_timestamp_ns, before - 1'000'000'000);
  EXPECT_LE(m.source_timestamp_ns, now_ns());
  EXPECT_GE(m.reception_ns, m.source_timestamp_ns - 1'000'000'000);
  EXPECT_LE(m.reception_ns, now_ns());
}

TEST(WriterReaderTest, LateReaderGetsNewestVersionOfMoreTilesThanDefaultInstanceLimit) {
  Node leader({111, kShm, "leader"});
  TileWriter writer(leader);
  constexpr int kTiles = 300;  // Fast DDS's default max_instances is 10
  for (std::uint64_t v = 1; v <= 2; ++v) {
    for (int i = 0; i < kTiles; ++i) ASSERT_TRUE(writer.write(tile(i % 20, i / 20, v)));
  }
  EXPECT_EQ(writer.samples_written(), 2u * kTiles);
  EXPECT_EQ(writer.write_failures(), 0u);

  Node follower({111, kShm, "follower"});
  Inbox<msg::MapTile> inbox;
  TileReader reader(follower, inbox.callback());
  ASSERT_TRUE(wait_until([&] { return reader.samples_received() >= kTiles; }))
      << reader.samples_received();
  std::this_thread::sleep_for(milliseconds(200));  // surplus samples would arrive now
  std::lock_guard lock(inbox.mutex);
  ASSERT_EQ(inbox.samples.size(), static_cast<std::size_t>(kTiles));
  std::map<std::pair<int, int>, std::uint64_t> newest;
  for (const auto& t : inbox.samples) newest[{t.tx(), t.ty()}] = t.version();
  EXPECT_EQ(newest.size(), static_cast<std::size_t>(kTiles));
  for (const auto& [key, version] : newest) EXPECT_EQ(version, 2u);
  EXPECT_TRUE(writer.wait_for_acknowledgments(milliseconds(2000)));
}

TEST(WriterReaderTest, WriteRefusesSamplesLongerThanTheBound) {
  // The types are bounded (protocol 3), so Fast DDS 2.9 gives the writer a preallocated pool of
  // the type's maximum size and a longer sample fails to serialize: a leader never sends what
  // its followers' readers refuse. (A hostile writer with a dynamic pool can send one; that it
  // never reaches the follower is security.rogue_peer's check.)
  Node leader({117, kShm, "leader"});
  Node follower({117, kShm, "follower"});
  Inbox<msg::MapTile> tiles;
  Inbox<msg::LaserScanMsg> scans;
  TileReader tile_reader(follower, tiles.callback());
  ScanReader scan_reader(follower, scans.callback());
  TileWriter tile_writer(leader);
  ScanWriter scan_writer(leader);
  ASSERT_TRUE(tile_writer.wait_for_matched(1, milliseconds(5000)));
  ASSERT_TRUE(scan_writer.wait_for_matched(1, milliseconds(5000)));

  msg::MapTile over = tile(2, 2, 1);
  over.payload(std::vector<std::uint8_t>(kTilePartBytes + 1000, 0x22));
  EXPECT_FALSE(tile_writer.write(over));
  msg::MapTile full = tile(1, 1, 1);
  full.map_id(std::string(64, 'm'));  // the longest key too
  full.payload(std::vector<std::uint8_t>(kTilePartBytes, 0x11));
  EXPECT_TRUE(tile_writer.write(full));

  msg::LaserScanMsg scan;
  scan.robot_id(std::string(64, 'r'));
  scan.protocol(kProtocolVersion);
  scan.max_range(30.0f);
  // The byte bound has the slack of the maximal alignment padding (a few bytes): one beam
  // too many still fits; scan_from_msg refuses it by count. 100 more do not fit.
  scan.ranges(std::vector<float>(msg::kMaxScanBeams + 100, 1.0f));
  EXPECT_FALSE(scan_writer.write(scan));
  scan.ranges(std::vector<float>(msg::kMaxScanBeams, 2.0f));
  EXPECT_TRUE(scan_writer.write(scan));
  EXPECT_EQ(tile_writer.write_failures(), 1u);
  EXPECT_EQ(scan_writer.write_failures(), 1u);

  // The samples at the bound arrive whole.
  ASSERT_TRUE(wait_until(
      [&] { return tile_reader.samples_received() >= 1 && scan_reader.samples_received() >= 1; }));
  std::lock_guard tile_lock(tiles.mutex);
  ASSERT_EQ(tiles.samples.size(), 1u);
  EXPECT_EQ(tiles.samples[0].payload(), full.payload());
  std::lock_guard scan_lock(scans.mutex);
  ASSERT_EQ(scans.samples.size(), 1u);
  EXPECT_EQ(scans.samples[0].ranges().size(), std::size_t{msg::kMaxScanBeams});
}

TEST(WriterReaderTest, WriteRefusesWrongProtocol) {
  Node node({112, kShm, ""});
  TileWriter writer(node);
  msg::MapTile t = tile(0, 0, 1);
  t.protocol(kProtocolVersion + 1);
  EXPECT_FALSE(writer.write(t));
  EXPECT_FALSE(writer.write(msg::MapTile{}));  // protocol 0
  EXPECT_EQ(writer.write_failures(), 2u);
  EXPECT_EQ(writer.samples_written(), 0u);
  EXPECT_EQ(writer.bytes_written(), 0u);
}

TEST(WriterReaderTest, EndpointsOutlivingTheirNodeAreInert) {
  auto node = std::make_unique<Node>(NodeOptions{113, kShm, ""});
  auto writer = std::make_unique<PoseWriter>(*node);
  std::atomic<int> calls{0};
  auto reader = std::make_unique<PoseReader>(
      *node, [&](const msg::RobotPose&, const SampleMeta&) { calls.fetch_add(1); });
  node.reset();
  msg::RobotPose pose;
  pose.protocol(kProtocolVersion);
  EXPECT_FALSE(writer->write(pose));
  EXPECT_EQ(writer->matched_readers(), 0);
  EXPECT_EQ(reader->matched_writers(), 0);
  EXPECT_FALSE(writer->wait_for_matched(1, milliseconds(20)));
  writer.reset();
  reader.reset();
  EXPECT_EQ(calls.load(), 0);
}

// A follower writes its contributions in its robot's partition, the leader reads them in every
// partition; the leader answers in the robot's partition, which another robot does not see.
TEST(WriterReaderTest, ContributionsReachTheLeaderAndTheAnswerOnlyTheirRobot) {
  Node leader({153, kShm, "leader"});
  Node robot7({153, kShm, "robot7"});
  Node robot8({153, kShm, "robot8"});
  Inbox<msg::ContributedScan> contributions;
  Inbox<msg::ContributionStatus> status7;
  Inbox<msg::ContributionStatus> status8;
  ContributionReader contribution_reader(leader, contributions.callback(), kAllPartitions);
  ContributionStatusReader status_reader7(robot7, status7.callback(), "robot7");
  ContributionStatusReader status_reader8(robot8, status8.callback(), "robot8");
  ContributionWriter contribution_writer(robot7, "robot7");
  ContributionStatusWriter status_writer(leader, "robot7");
  EXPECT_EQ(contribution_writer.topic_name(), "esfleet/robots/contribution");
  EXPECT_EQ(status_writer.topic_name(), "esfleet/robots/contribution_status");
  ASSERT_TRUE(contribution_writer.wait_for_matched(1, milliseconds(5000)));
  ASSERT_TRUE(status_writer.wait_for_matched(1, milliseconds(5000)));

  esfleet::Contribution c;
  c.robot = "robot7";
  c.seq = 3;
  c.pose = esfleet::Pose2{1.5, -2.0, 0.25};
  c.scan.stamp = 42.0;
  c.scan.angle_min = -1.5f;
  c.scan.angle_increment = 0.01f;
  c.scan.max_range = 30.0f;
  c.scan.ranges.assign(361, 2.5f);
  ASSERT_TRUE(contribution_writer.write(contribution_to_msg(c, {"map", 9, 0.9f, 0.8f})));
  ASSERT_TRUE(wait_until([&] { return contribution_reader.samples_received() == 1; }));
  {
    std::lock_guard lock(contributions.mutex);
    const ReceivedContribution r = contribution_from_msg(contributions.samples.at(0));
    EXPECT_EQ(r.contribution.robot, "robot7");
    EXPECT_EQ(r.contribution.seq, 3u);
    EXPECT_EQ(r.contribution.pose, c.pose);
    EXPECT_EQ(r.contribution.scan.ranges, c.scan.ranges);
    EXPECT_EQ(r.claim.epoch, 9u);
  }
  // One RTPS message per contribution: a 361-beam scan is well below 1284 bytes.
  EXPECT_LT(contribution_writer.bytes_written(), 1284u);

  ContributionTally t;
  t.last_seq = 3;
  t.last_verdict = esfleet::ContributionVerdict::kDisagrees;
  t.rejected = 1;
  t.rejected_in_row = 1;
  ASSERT_TRUE(status_writer.write(contribution_status_to_msg("robot7", t)));
  ASSERT_TRUE(wait_until([&] { return status_reader7.samples_received() == 1; }));
  std::this_thread::sleep_for(milliseconds(200));
  EXPECT_EQ(status_reader8.samples_received(), 0u);
  std::lock_guard lock(status7.mutex);
  EXPECT_EQ(contribution_status_from_msg(status7.samples.at(0)).last_verdict,
            esfleet::ContributionVerdict::kDisagrees);
}

TEST(WriterReaderTest, ReaderRejectsEmptyCallbackAndCountsThrowingOnes) {
  Node node({114, kShm, ""});
  EXPECT_THROW(TileReader(node, nullptr), std::invalid_argument);
  PoseReader reader(node, [](const msg::RobotPose&, const SampleMeta&) {
    throw std::runtime_error("callback failure");
  });
  PoseWriter writer(node);
  ASSERT_TRUE(writer.wait_for_matched(1, milliseconds(5000)));
  msg::RobotPose pose;
  pose.robot_id("r");
  pose.protocol(kProtocolVersion);
  ASSERT_TRUE(writer.write(pose));
  ASSERT_TRUE(wait_until([&] { return reader.samples_received() == 1; }));
  EXPECT_EQ(reader.callback_errors(), 1u);
  EXPECT_EQ(reader.protocol_mismatches(), 0u);
}

}  // namespace
