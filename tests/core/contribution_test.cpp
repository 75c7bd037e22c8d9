// Contributed scans (Slam::contribute) in the synthetic room: a follower's scans extend the
// leader's map where the leader never looked; a wrong pose never changes the map; the result
// is deterministic and survives a checkpoint.

#include "esfleet/core/contribution.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "esfleet/core/slam.hpp"
#include "esfleet/core/slam_snapshot.hpp"
#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;

const Pose2 kStart{5.0, 3.8, 0.0};  ///< the leader's first pose in the world: the map's origin

Pose2 to_map(const Pose2& world) { return world.relative_to(kStart); }

/// A leader that drove from x = 5 to 10 looking ahead (+x) only: the left of the room is
/// unknown to it.
Slam leader_of_right_half() {
  Slam slam;
  const auto world = asymmetric_room();
  int i = 0;
  for (double x = 5.0; x <= 10.0; x += 0.1) {
    slam.process(make_scan(world, {x, 3.8, 0.0}, 0.2 * i++));
  }
  return slam;
}

Contribution contribution(const Pose2& world_truth, const Pose2& claimed_world, std::uint32_t seq,
                          const std::string& robot = "robot1") {
  Contribution c;
  c.robot = robot;
  c.seq = seq;
  c.scan = make_scan(asymmetric_room(), world_truth, 100.0 + seq);
  c.pose = to_map(claimed_world);
  return c;
}

/// Cells with any observation left of x = 4.5 in the world.
std::size_t known_left(const GridMap& map) {
  std::size_t n = 0;
  for (double x = 0.1; x < 4.5; x += map.cell_size()) {
    for (double y = 0.1; y < 7.9; y += map.cell_size()) {
      const Pose2 p = to_map({x, y, 0.0});
      const CellIndex c = map.cell_of(p.x, p.y);
      if (map.hit(c) + map.err(c) > 0) ++n;
    }
  }
  return n;
}

/// Every tile's key and version: equal iff no tile changed.
std::vector<std::pair<TileKey, std::uint64_t>> versions(const GridMap& map) {
  std::vector<std::pair<TileKey, std::uint64_t>> v;
  for (const TileKey& k : map.tile_keys()) v.emplace_back(k, map.find_tile(k)->version);
  return v;
}

/// A follower turning on the spot at (6, 3.8) from facing ahead to facing back, contributing
/// every 0.2 rad (11.5 degrees: none redundant with the one before).
std::vector<ContributionResult> turn_and_contribute(Slam& slam, const std::string& robot) {
  std::vector<ContributionResult> results;
  std::uint32_t seq = 0;
  for (double th = 0.3; th <= std::numbers::pi; th += 0.2) {
    const Pose2 p{6.0, 3.8, th};
    results.push_back(slam.contribute(contribution(p, p, seq++, robot)));
  }
  return results;
}

TEST(Contribution, FollowerScansExtendTheMapWhereTheLeaderNeverLooked) {
  Slam slam = leader_of_right_half();
  const std::size_t before = known_left(slam.map());
  const std::size_t keys_before = slam.key_scans();
  const auto results = turn_and_contribute(slam, "robot1");
  std::size_t accepted = 0;
  for (const ContributionResult& r : results) {
    if (r.accepted()) ++accepted;
    EXPECT_LE(r.moved_xy, 0.1);
  }
  EXPECT_GE(accepted, results.size() * 9 / 10) << accepted << " of " << results.size();
  EXPECT_GT(known_left(slam.map()), before + 1000) << "before " << before;
  EXPECT_EQ(slam.contributed_keys(), accepted);
  EXPECT_EQ(slam.key_scans(), keys_before + accepted);
  ASSERT_EQ(slam.contributors().size(), 1u);
  EXPECT_EQ(slam.contributors()[0], "robot1");
  EXPECT_EQ(slam.keys().back().contributor, 1u);
  EXPECT_EQ(slam.keys().back().path_length, kContributedPathLength);
}

TEST(Contribution, AWrongPoseIsRejectedAndTheMapStaysAsItWas) {
  Slam slam = leader_of_right_half();
  const auto map_before = versions(slam.map());
  const std::size_t keys_before = slam.key_scans();
  // Far off: 1 m and 25 degrees.
  const ContributionResult far =
      slam.contribute(contribution({7.0, 3.0, 0.2}, {8.0, 3.6, 0.2 + 0.44}, 1));
  EXPECT_FALSE(far.accepted()) << to_string(far.verdict);
  // Near but wrong: 0.3 m sideways, which the refine would have to undo.
  const ContributionResult near =
      slam.contribute(contribution({7.0, 3.0, 0.2}, {7.0, 3.3, 0.2}, 2));
  EXPECT_FALSE(near.accepted()) << to_string(near.verdict);
  EXPECT_EQ(versions(slam.map()), map_before);
  EXPECT_EQ(slam.key_scans(), keys_before);
  EXPECT_EQ(slam.contributed_keys(), 0u);
  // A scan seen from where the map knows nothing is not taken on trust either.
  const ContributionResult unknown =
      slam.contribute(contribution({2.0, 7.0, 2.5}, {2.0, 7.0, 2.5}, 3));
  EXPECT_EQ(unknown.verdict, ContributionVerdict::kUnknownPlace);
  EXPECT_EQ(versions(slam.map()), map_before);
  // The right pose of the same scan is accepted.
  EXPECT_TRUE(slam.contribute(contribution({7.0, 3.0, 0.2}, {7.0, 3.0, 0.2}, 4)).accepted());
}

TEST(Contribution, AScanWhereAKeyScanAlreadyIsIsSkippedNotRejected) {
  Slam slam = leader_of_right_half();
  const Pose2 p{6.0, 3.8, 0.8};
  ASSERT_TRUE(slam.contribute(contribution(p, p, 1)).accepted());
  const auto map_before = versions(slam.map());
  // Another robot 0.1 m and 5 degrees from the scan just inserted.
  const Pose2 q{6.1, 3.8, 0.8 + deg_to_rad(5.0)};
  const ContributionResult r = slam.contribute(contribution(q, q, 2, "robot2"));
  EXPECT_EQ(r.verdict, ContributionVerdict::kRedundant);
  EXPECT_FALSE(r.accepted());
  EXPECT_FALSE(r.rejected());
  EXPECT_EQ(versions(slam.map()), map_before);
  EXPECT_EQ(slam.contributed_keys(), 1u);
  // A wrong pose there is still a rejection, not a skip.
  const ContributionResult wrong = slam.contribute(contribution(q, {6.1, 3.3, 1.0}, 3, "robot2"));
  EXPECT_TRUE(wrong.rejected()) << to_string(wrong.verdict);
  // The contributor's own recent scans do not count: in new space it extends the map at the
  // key-scan spacing.
  EXPECT_TRUE(slam.contribute(contribution(q, q, 4)).accepted());
  // With the check off, the same scan is inserted.
  SlamConfig off;
  off.contribution.redundant_xy = 0.0;
  Slam all(off);
  const auto world = asymmetric_room();
  int i = 0;
  for (double x = 5.0; x <= 10.0; x += 0.1) all.process(make_scan(world, {x, 3.8, 0.0}, 0.2 * i++));
  ASSERT_TRUE(all.contribute(contribution(p, p, 1)).accepted());
  EXPECT_TRUE(all.contribute(contribution(q, q, 2, "robot2")).accepted());
}

TEST(Contribution, BeamsThroughCellsSeenOccupiedManyTimesContradictTheMap) {
  // A map that has seen the inner wall (x = 4, y 0..3) many times.
  const auto world = asymmetric_room();
  GridMap map;
  for (int i = 0; i < 10; ++i) {
    const Pose2 p{6.0, 1.5, std::numbers::pi};
    update_map(map, prepare_scan(make_scan(world, p)), p);
  }
  // The same room without that wall: beams from (6, 1.5) to the left now pass through it.
  auto open = world;
  open.erase(open.begin() + 4);
  const Pose2 p{6.0, 1.5, std::numbers::pi};
  const ScanPoints through = prepare_scan(make_scan(open, p));
  const float share = occupied_contradiction(map, through, p, 5, 0.25);
  EXPECT_GT(share, 0.2f);
  // The room as the map saw it contradicts nothing.
  EXPECT_LT(occupied_contradiction(map, prepare_scan(make_scan(world, p)), p, 5, 0.25), 0.01f);
  // Seen once only, the wall is not "many times".
  GridMap once;
  update_map(once, prepare_scan(make_scan(world, p)), p);
  EXPECT_EQ(occupied_contradiction(once, through, p, 5, 0.25), 0.0f);
}

TEST(Contribution, SameInputsGiveTheSameMapAndGraph) {
  Slam a = leader_of_right_half();
  Slam b = leader_of_right_half();
  const auto ra = turn_and_contribute(a, "robot1");
  const auto rb = turn_and_contribute(b, "robot1");
  ASSERT_EQ(ra.size(), rb.size());
  for (std::size_t i = 0; i < ra.size(); ++i) {
    EXPECT_EQ(ra[i].verdict, rb[i].verdict);
    EXPECT_EQ(ra[i].refined.x, rb[i].refined.x);
    EXPECT_EQ(ra[i].refined.theta, rb[i].refined.theta);
  }
  EXPECT_EQ(versions(a.map()), versions(b.map()));
  for (const TileKey& k : a.map().tile_keys()) {
    ASSERT_EQ(a.map().find_tile(k)->hit, b.map().find_tile(k)->hit);
  }
}

TEST(Contribution, ContributedKeyScansSurviveACheckpoint) {
  Slam slam = leader_of_right_half();
  turn_and_contribute(slam, "robot7");
  ASSERT_GT(slam.contributed_keys(), 0u);
  const SlamState state = decode_slam_state(encode_slam_state(slam.state()));
  ASSERT_EQ(state.contributors, std::vector<std::string>{"robot7"});
  std::size_t contributed = 0;
  for (const KeyScan& k : state.keys) contributed += k.contributor == 1 ? 1 : 0;
  EXPECT_EQ(contributed, slam.contributed_keys());
  Slam resumed;
  resumed.restore(state);
  EXPECT_EQ(resumed.contributed_keys(), slam.contributed_keys());
  EXPECT_EQ(resumed.contributors(), slam.contributors());
  // The leader goes on from its own last key scan, not from a contributed one.
  const SlamState again = resumed.state();
  EXPECT_EQ(again.last_inserted->x, state.last_inserted->x);
}

TEST(ContributionConfig, ValidateNamesTheField) {
  ContributionConfig c;
  c.min_agreement = 1.5;
  try {
    c.validate();
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("contribution.min_agreement"), std::string::npos);
  }
}

}  // namespace
}  // namespace esfleet
