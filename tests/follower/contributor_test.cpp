// The follower's Contributor (follower/contributor.hpp) between real participants of one
// process (domain 154): which tracked scans it sends and with what, and when the leader's
// answers make it relocalise (only rejections of scans sent since the last relocalisation).

#include "contributor.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "dds_test_support.hpp"
#include "esfleet/dds/from_msg.hpp"
#include "esfleet/mapshare/tile_sender.hpp"
#include "synthetic_world.hpp"

namespace esfleet::follower {
namespace {

using std::chrono::milliseconds;

mapshare::MapReplica shared_map() {
  GridMap map = esfleet::testing::map_of(esfleet::testing::asymmetric_room(), 12, 8);
  mapshare::MapReplica replica;
  mapshare::TileSender sender({"fleet", 4});
  sender.republish_all(map);
  const mapshare::Publication p = sender.publish(map, 0, true, false, 1, "{}", 0);
  for (const auto& t : p.tiles) EXPECT_EQ(replica.apply(t), mapshare::Applied::kApplied);
  EXPECT_EQ(replica.apply(p.meta), mapshare::Applied::kApplied);
  return replica;
}

LocaliserStep tracked(Pose2 pose, int n_hit, int n_known, int n_points) {
  LocaliserStep s;
  s.state = LocaliserState::kTracking;
  s.pose = pose;
  s.value.n_hit = n_hit;
  s.value.n_known = n_known;
  s.value.n_points = n_points;
  return s;
}

LaserScan scan_at(double stamp) {
  LaserScan s;
  s.stamp = stamp;
  s.angle_min = -1.5f;
  s.angle_increment = 0.01f;
  s.max_range = 30.0f;
  s.ranges.assign(301, 3.0f);
  return s;
}

struct Leader {
  dds::Node node{{154, esfleet::test::kShmProfile, "leader"}};
  std::mutex mutex;
  std::vector<dds::ReceivedContribution> received;
  dds::ContributionReader reader{node,
                                 [this](const msg::ContributedScan& m, const dds::SampleMeta&) {
                                   std::lock_guard lock(mutex);
                                   received.push_back(dds::contribution_from_msg(m));
                                 },
                                 dds::kAllPartitions};
  dds::ContributionStatusWriter status{node, "r1"};
  dds::ContributionTally tally;
  /// Answers the newest contribution as refused (or accepted).
  void answer(bool accept) {
    std::uint32_t seq = 0;
    {
      std::lock_guard lock(mutex);
      seq = received.back().contribution.seq;
    }
    tally.last_seq = seq;
    tally.last_verdict = accept ? ContributionVerdict::kAccepted : ContributionVerdict::kDisagrees;
    accept ? ++tally.accepted : ++tally.rejected;
    tally.rejected_in_row = accept ? 0 : tally.rejected_in_row + 1;
    tally.stamp_ns += 1;
    ASSERT_TRUE(status.write(dds::contribution_status_to_msg("r1", tally)));
  }
  std::size_t count() {
    std::lock_guard lock(mutex);
    return received.size();
  }
};

TEST(Contributor, SendsTrackedScansWithEvidenceAndRelocalisesAfterRefusals) {
  Leader leader;
  dds::Node robot({154, esfleet::test::kShmProfile, "robot"});
  ContributorConfig config;
  config.enabled = true;
  config.max_rejections = 3;
  config.pose_offset = Pose2{0.5, 0.0, 0.0};
  Contributor contributor(robot, "r1", config);
  ASSERT_TRUE(leader.reader.wait_for_matched(1, milliseconds(5000)));
  ASSERT_TRUE(leader.status.wait_for_matched(1, milliseconds(5000)));
  // The reader matched the writer; the writer must match it too, or the first sent is lost
  // (failed twice here while valgrind loaded the machine).
  ASSERT_TRUE(contributor.wait_for_leader(milliseconds(5000)));
  const mapshare::MapReplica replica = shared_map();
  const mapshare::MapReplica none;

  // Not sent: no map, not tracking before, the declaring scan, weak evidence.
  Pose2 pose{2.0, 1.5, 0.3};
  EXPECT_FALSE(contributor.after_scan(scan_at(1), tracked(pose, 90, 100, 100), true, none));
  EXPECT_FALSE(contributor.after_scan(scan_at(1), tracked(pose, 90, 100, 100), false, replica));
  LocaliserStep declared = tracked(pose, 90, 100, 100);
  declared.declared = true;
  EXPECT_FALSE(contributor.after_scan(scan_at(1), declared, true, replica));
  EXPECT_FALSE(contributor.after_scan(scan_at(1), tracked(pose, 70, 100, 100), true, replica));
  EXPECT_FALSE(contributor.after_scan(scan_at(1), tracked(pose, 90, 40, 100), true, replica));
  // Sent, then not again before the robot moved 0.1 m or turned 5 deg.
  EXPECT_TRUE(contributor.after_scan(scan_at(2), tracked(pose, 90, 100, 100), true, replica));
  EXPECT_FALSE(contributor.after_scan(scan_at(3), tracked(pose, 90, 100, 100), true, replica));
  pose.theta += 0.1;
  EXPECT_TRUE(contributor.after_scan(scan_at(4), tracked(pose, 90, 100, 100), true, replica));
  ASSERT_TRUE(esfleet::test::wait_until([&] { return leader.count() == 2; }));
  {
    std::lock_guard lock(leader.mutex);
    const dds::ReceivedContribution& r = leader.received.back();
    EXPECT_EQ(r.contribution.robot, "r1");
    EXPECT_EQ(r.contribution.seq, 2u);
    EXPECT_NEAR(r.contribution.pose.x, 2.5, 1e-12);  // the test offset
    EXPECT_EQ(r.claim.map_id, "fleet");
    EXPECT_EQ(r.claim.epoch, 4u);
    EXPECT_FLOAT_EQ(r.claim.agreement, 0.9f);
    EXPECT_FLOAT_EQ(r.claim.known, 1.0f);
  }
  EXPECT_FALSE(contributor.answered());

  // Refused three times in a row: relocalise once, not again for the same answer.
  leader.answer(false);
  for (int i = 0; i < 2; ++i) {
    pose.x += 0.2;
    ASSERT_TRUE(contributor.after_scan(scan_at(5 + i), tracked(pose, 90, 100, 100), true, replica));
    ASSERT_TRUE(esfleet::test::wait_until([&] { return leader.count() == 3u + i; }));
    leader.answer(false);
  }
  ASSERT_TRUE(esfleet::test::wait_until([&] { return contributor.answered(); }));
  EXPECT_TRUE(contributor.take_relocalise());
  EXPECT_FALSE(contributor.take_relocalise());
  EXPECT_EQ(contributor.relocalisations(), 1u);

  // The leader's row goes on, but only refusals of scans sent since then count.
  pose.x += 0.2;
  ASSERT_TRUE(contributor.after_scan(scan_at(9), tracked(pose, 90, 100, 100), true, replica));
  ASSERT_TRUE(esfleet::test::wait_until([&] { return leader.count() == 5; }));
  leader.answer(false);  // rejected_in_row 4, but 1 since the relocalisation
  ASSERT_TRUE(esfleet::test::wait_until([&] { return contributor.answered(); }));
  EXPECT_FALSE(contributor.take_relocalise());
  const nlohmann::json j = contributor.json();
  EXPECT_EQ(j["sent"], 5);
  EXPECT_EQ(j["rejected"], 4);
  EXPECT_EQ(j["accepted"], 0);
  EXPECT_EQ(j["relocalisations"], 1);
  EXPECT_EQ(j["last_verdict"], "disagrees");
  EXPECT_GT(j["bytes"].get<std::uint64_t>(), 5u * 600u);
}

}  // namespace
}  // namespace esfleet::follower
