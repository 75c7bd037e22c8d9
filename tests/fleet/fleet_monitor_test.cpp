// The fleet launcher's bookkeeping: matching poses with truth, declarations, lost events, and
// reading CPU and memory from /proc.
#include "fleet_monitor.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace esfleet::fleet {
namespace {

constexpr std::uint8_t kLocalising = 2;

PoseSample pose(const std::string& id, double stamp, double x, double y, double th,
                std::uint8_t status) {
  return {id, stamp, x, y, th, status};
}

TEST(FleetMonitor, MatchesTrackingPosesWithTruthOfTheSameStamp) {
  FleetMonitor m;
  m.add_robot("robot-1");
  m.on_truth({"robot-1", 10.0, 1.0, 2.0, 0.0});
  m.on_truth({"robot-1", 10.2, 1.1, 2.0, 0.0});
  m.on_pose(pose("robot-1", 10.0, 0.0, 0.0, 0.0, kLocalising), 1.0);
  m.on_pose(pose("robot-1", 10.2, 1.1, 2.1, 0.01, kStatusTracking), 2.0);
  const RobotReport& r = m.robots().at("robot-1");
  EXPECT_EQ(r.poses, 2u);
  EXPECT_EQ(r.tracking_poses, 1u);
  EXPECT_EQ(r.declarations, 1u);
  ASSERT_TRUE(r.localised_s);
  EXPECT_DOUBLE_EQ(*r.localised_s, 2.0);
  ASSERT_EQ(r.matched, 1u);
  EXPECT_NEAR(r.error_xy_m[0], 0.1, 1e-9);
  EXPECT_NEAR(r.error_theta_rad[0], 0.01, 1e-9);
  EXPECT_EQ(r.wrong_declarations, 0u);
}

TEST(FleetMonitor, PoseBeforeItsTruthWaitsForIt) {
  FleetMonitor m;
  m.add_robot("robot-1");
  m.on_pose(pose("robot-1", 5.0, 3.0, 0.0, 0.0, kStatusTracking), 1.0);
  EXPECT_EQ(m.robots().at("robot-1").matched, 0u);
  m.on_truth({"robot-1", 4.8, 0.0, 0.0, 0.0});
  EXPECT_EQ(m.robots().at("robot-1").matched, 0u);
  m.on_truth({"robot-1", 5.0, 0.0, 0.0, 0.0});
  const RobotReport& r = m.robots().at("robot-1");
  ASSERT_EQ(r.matched, 1u);
  // 3 m off: the declaration is wrong.
  EXPECT_EQ(r.wrong_declarations, 1u);
  ASSERT_TRUE(r.first_error_xy_m);
  EXPECT_NEAR(*r.first_error_xy_m, 3.0, 1e-9);
}

TEST(FleetMonitor, HeadingBeyondToleranceIsWrongAcrossTheWrap) {
  FleetMonitor m;
  m.add_robot("r");
  m.on_truth({"r", 1.0, 0.0, 0.0, M_PI - 0.01});
  m.on_pose(pose("r", 1.0, 0.0, 0.0, -M_PI + 0.01, kStatusTracking), 0.5);
  const RobotReport& r = m.robots().at("r");
  ASSERT_EQ(r.matched, 1u);
  EXPECT_NEAR(r.error_theta_rad[0], 0.02, 1e-9);  // not 2 pi - 0.02
  EXPECT_EQ(r.wrong_declarations, 0u);
  m.on_truth({"r", 2.0, 0.0, 0.0, 0.0});
  m.on_pose(pose("r", 2.0, 0.0, 0.0, 0.2, kStatusLost), 1.0);
  m.on_truth({"r", 3.0, 0.0, 0.0, 0.0});
  m.on_pose(pose("r", 3.0, 0.0, 0.0, 0.2, kStatusTracking), 1.5);  // 11.5 deg off
  EXPECT_EQ(r.lost_events, 1u);
  EXPECT_EQ(r.declarations, 2u);
  EXPECT_EQ(r.wrong_declarations, 1u);
  // Only the first declaration's error is kept as the first pose's.
  EXPECT_NEAR(*r.first_error_theta_rad, 0.02, 1e-9);
}

TEST(FleetMonitor, IgnoresUnknownRobotsAndBoundsItsBuffers) {
  FleetMonitor m;
  m.add_robot("robot-1");
  m.on_pose(pose("leader", 1.0, 0.0, 0.0, 0.0, 0), 0.0);
  m.on_truth({"robot-9", 1.0, 0.0, 0.0, 0.0});
  EXPECT_EQ(m.ignored(), 2u);
  for (int i = 0; i < 5000; ++i) {
    m.on_pose(pose("robot-1", 1000.0 + i, 0.0, 0.0, 0.0, kStatusTracking), 0.0);
    m.on_truth({"robot-1", static_cast<double>(i), 0.0, 0.0, 0.0});
  }
  // No stamp ever matched: the poses are far ahead of the truth, and old ones were dropped.
  EXPECT_EQ(m.robots().at("robot-1").matched, 0u);
  m.on_truth({"robot-1", 1000.0 + 4999, 0.0, 0.0, 0.0});
  EXPECT_EQ(m.robots().at("robot-1").matched, 1u);
  m.on_truth({"robot-1", 1000.0, 0.0, 0.0, 0.0});  // long gone from the pending buffer
  EXPECT_EQ(m.robots().at("robot-1").matched, 1u);
}

TEST(FleetMonitor, WindowCountsScansAndTrackingPosesOnceAllTrack) {
  FleetMonitor m;
  m.add_robot("a");
  m.add_robot("b");
  EXPECT_FALSE(m.all_tracking());
  m.on_pose(pose("a", 1.0, 0, 0, 0, kStatusTracking), 0.0);
  m.on_pose(pose("b", 1.0, 0, 0, 0, kLocalising), 0.0);
  EXPECT_FALSE(m.all_tracking());
  m.on_truth({"a", 1.0, 0, 0, 0});
  EXPECT_EQ(m.robots().at("a").window_truth, 0u);  // no window yet
  m.on_pose(pose("b", 2.0, 0, 0, 0, kStatusTracking), 0.0);
  ASSERT_TRUE(m.all_tracking());
  m.start_window();
  for (int i = 0; i < 10; ++i) {
    m.on_truth({"a", 10.0 + i, 0, 0, 0});
    m.on_truth({"b", 10.0 + i, 0, 0, 0});
    m.on_pose(pose("a", 10.0 + i, 0, 0, 0, kStatusTracking), 1.0);
    if (i % 2 == 0) m.on_pose(pose("b", 10.0 + i, 0, 0, 0, kStatusTracking), 1.0);  // b skips
  }
  EXPECT_EQ(m.robots().at("a").window_truth, 10u);
  EXPECT_EQ(m.robots().at("a").window_tracking_poses, 10u);
  EXPECT_EQ(m.robots().at("b").window_truth, 10u);
  EXPECT_EQ(m.robots().at("b").window_tracking_poses, 5u);
}

TEST(ProcParsing, StatTicksCountFieldsAfterTheLastParenthesis) {
  // Field 14 (utime) = 120, 15 (stime) = 30; the command contains ") (" and spaces.
  const std::string stat = "4242 (a) (b c) S 1 4242 4242 0 -1 4194560 100 0 0 0 120 30 0 0 20 0";
  ASSERT_TRUE(parse_proc_stat_ticks(stat));
  EXPECT_EQ(*parse_proc_stat_ticks(stat), 150u);
  EXPECT_FALSE(parse_proc_stat_ticks("4242 (x) S 1 2"));
  EXPECT_FALSE(parse_proc_stat_ticks("garbage"));
  EXPECT_FALSE(parse_proc_stat_ticks("1 (x) S 1 1 1 0 -1 0 0 0 0 0 abc 3"));
}

TEST(ProcParsing, StatusRss) {
  EXPECT_EQ(parse_proc_status_rss_kb("Name:\tx\nVmPeak:\t 10 kB\nVmRSS:\t   35120 kB\n"),
            std::optional<std::uint64_t>(35120));
  EXPECT_FALSE(parse_proc_status_rss_kb("Name:\tkthread\n"));
}

}  // namespace
}  // namespace esfleet::fleet
