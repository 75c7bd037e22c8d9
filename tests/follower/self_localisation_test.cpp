// The follower's own localisation loop in a map that reaches it through the map-sharing
// protocol (TileSender -> MapReplica, no network): it waits for the map, localises in the
// replica, tracks, and localises afresh when the leader starts a new map (epoch).

#include "self_localisation.hpp"

#include <esfleet/msg/esfleet.h>

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "esfleet/mapshare/tile_sender.hpp"
#include "synthetic_world.hpp"

namespace esfleet::follower {
namespace {

using esfleet::testing::asymmetric_room;
using esfleet::testing::make_scan;

/// A replica holding `map` as the leader would share it, with the localiser's pyramid.
mapshare::MapReplica shared(GridMap& map, std::uint32_t epoch) {
  GridMapConfig local;
  local.pyramid_levels = 3;
  mapshare::MapReplica replica({}, local);
  mapshare::TileSender sender({"map", epoch});
  sender.republish_all(map);
  const mapshare::Publication p = sender.publish(map, 0, true, false, 1, "{}", 0);
  for (const auto& t : p.tiles) EXPECT_EQ(replica.apply(t), mapshare::Applied::kApplied);
  EXPECT_EQ(replica.apply(p.meta), mapshare::Applied::kApplied);
  return replica;
}

Pose2 along(int i) {  // a straight drive through the room, 0.1 m per scan
  return {2.0 + 0.1 * i * std::cos(0.3), 1.5 + 0.1 * i * std::sin(0.3), 0.3};
}

TEST(SelfLocalisation, ResetLocalisesAfreshAndIsCounted) {
  const auto world = asymmetric_room();
  GridMap map = esfleet::testing::map_of(world, 12, 8);
  LocaliserConfig c;
  c.seed = 2;
  SelfLocalisation loc(c);
  const mapshare::MapReplica replica = shared(map, 1);
  int i = 0;
  for (; i < 60 && loc.state() != LocaliserState::kTracking; ++i) {
    loc.process(replica, make_scan(world, along(i), 0.2 * i));
  }
  ASSERT_EQ(loc.state(), LocaliserState::kTracking) << "seed 2: no pose declared";
  EXPECT_EQ(loc.resets(), 0u);
  loc.reset();  // the leader refused this robot's scans: its pose is in doubt
  EXPECT_EQ(loc.resets(), 1u);
  const LocaliserStep s = loc.process(replica, make_scan(world, along(i), 0.2 * i));
  EXPECT_EQ(s.state, LocaliserState::kLocalising);  // what the pose topic then says
  EXPECT_EQ(status_of(s.state), msg::kStatusLocalising);
  EXPECT_EQ(loc.json("r")["resets"], 1);
}

TEST(SelfLocalisation, WaitsForTheMapLocalisesInTheReplicaAndTracks) {
  const auto world = asymmetric_room();
  GridMap map = esfleet::testing::map_of(world, 12, 8);
  LocaliserConfig c;
  c.seed = 2;
  SelfLocalisation loc(c);
  const mapshare::MapReplica none;
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(loc.process(none, make_scan(world, along(0), 0.2 * i)).state,
              LocaliserState::kWaitingForMap);
  }
  const mapshare::MapReplica replica = shared(map, 1);
  int declared_at = -1;
  for (int i = 0; i < 60; ++i) {
    const LocaliserStep s = loc.process(replica, make_scan(world, along(i), 1.0 + 0.2 * i));
    if (s.declared) declared_at = i;
    if (s.state == LocaliserState::kTracking) {
      EXPECT_LT(std::hypot(s.pose.x - along(i).x, s.pose.y - along(i).y), 0.05) << "scan " << i;
    }
  }
  ASSERT_GE(declared_at, 0) << "seed 2: no pose declared";
  EXPECT_EQ(loc.state(), LocaliserState::kTracking);
  const LocalisationStats& st = loc.stats();
  EXPECT_EQ(st.scans, 63u);
  EXPECT_EQ(st.scans_waiting_for_map, 3u);
  EXPECT_EQ(st.declarations, 1u);
  EXPECT_EQ(st.lost_events, 0u);
  EXPECT_GE(st.global_searches, 1u);
  ASSERT_TRUE(st.first_pose.has_value());
  EXPECT_DOUBLE_EQ(st.first_pose->stamp, 1.0 + 0.2 * declared_at);
  // One trajectory pose per tracked scan (the declaring one included), one CPU figure per
  // tracked scan after it.
  EXPECT_EQ(loc.trajectory().size(), static_cast<std::size_t>(60 - declared_at));
  EXPECT_EQ(st.tracking_cpu_ms.size(), loc.trajectory().size() - 1);
  EXPECT_GT(st.scans_to_first_pose, 0u);
  const nlohmann::json j = loc.json("robot-1");
  EXPECT_EQ(j["state"], "tracking");
  EXPECT_EQ(j["tracked_scans"], loc.trajectory().size());
  EXPECT_EQ(j["robot_id"], "robot-1");
  EXPECT_TRUE(j.contains("first_pose"));
}

TEST(SelfLocalisation, ANewEpochOfTheLeadersMapStartsTheLocalisationAfresh) {
  const auto world = asymmetric_room();
  GridMap map = esfleet::testing::map_of(world, 12, 8);
  LocaliserConfig c;
  c.seed = 3;
  SelfLocalisation loc(c);
  const mapshare::MapReplica first = shared(map, 1);
  int i = 0;
  for (; i < 60 && loc.state() != LocaliserState::kTracking; ++i) {
    loc.process(first, make_scan(world, along(i), 0.2 * i));
  }
  ASSERT_EQ(loc.state(), LocaliserState::kTracking) << "seed 3";
  // The same tiles under a new epoch (the leader restarted without --resume).
  const mapshare::MapReplica second = shared(map, 2);
  const LocaliserStep s = loc.process(second, make_scan(world, along(i), 0.2 * i));
  EXPECT_NE(s.state, LocaliserState::kTracking);
  EXPECT_FALSE(s.declared);
}

TEST(SelfLocalisation, StatusCodesAreThePoseTopics) {
  EXPECT_EQ(status_of(LocaliserState::kWaitingForMap), esfleet::msg::kStatusWaitingForMap);
  EXPECT_EQ(status_of(LocaliserState::kLocalising), esfleet::msg::kStatusLocalising);
  EXPECT_EQ(status_of(LocaliserState::kTracking), esfleet::msg::kStatusTracking);
  EXPECT_EQ(status_of(LocaliserState::kLost), esfleet::msg::kStatusLost);
}

}  // namespace
}  // namespace esfleet::follower
