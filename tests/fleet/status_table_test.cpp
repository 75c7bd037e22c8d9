// The launcher's status table, rendered from hand-made children and monitor state.
#include "status_table.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace esfleet::fleet {
namespace {

/// A monitor with robot-1 (n localising poses, then a tracking pose declared at now_s 15 s
/// and scored against a truth 0.2 m away) and robot-2 (no pose).
FleetMonitor monitor_with_poses(std::size_t n) {
  FleetMonitor m;
  m.add_robot("robot-1");
  m.add_robot("robot-2");
  for (std::size_t i = 0; i < n; ++i) {
    m.on_pose({"robot-1", static_cast<double>(i), 0, 0, 0, kStatusLocalising}, 10.0);
  }
  m.on_truth({"robot-1", 100.0, 1.2, 0.0, 0.0});
  m.on_pose({"robot-1", 100.0, 1.0, 0.0, 0.0, kStatusTracking}, 15.0);
  return m;
}

std::vector<ChildProcess> followers() {
  std::vector<ChildProcess> f(2);
  f[0].name = "robot-1";
  f[0].pid = 100;
  f[0].cpu_percent = 42.0;
  f[0].rss_kb = 2048;
  f[1].name = "robot-2";
  f[1].pid = 101;
  f[1].exited = true;
  return f;
}

/// The line of `robot` in `table`.
std::string line_of(const std::string& table, const std::string& robot) {
  const auto at = table.find("  " + robot + " ");
  if (at == std::string::npos) return "";
  return table.substr(at, table.find('\n', at) - at);
}

TEST(StatusName, NamesEveryStatus) {
  EXPECT_STREQ(status_name(kStatusMapping), "mapping");
  EXPECT_STREQ(status_name(kStatusWaitingForMap), "waiting-map");
  EXPECT_STREQ(status_name(kStatusLocalising), "localising");
  EXPECT_STREQ(status_name(kStatusTracking), "tracking");
  EXPECT_STREQ(status_name(kStatusLost), "lost");
  EXPECT_STREQ(status_name(kStatusNone), "-");
}

TEST(StatusTable, HeaderSaysRunTimeAndMapProgress) {
  StatusTable t;
  ChildProcess leader, sim;
  leader.cpu_percent = 97.0;
  leader.rss_kb = 100 * 1024;
  const FleetMonitor m = monitor_with_poses(0);
  StatusHeader h{2, 7, 12.4, 60.0, 5.0, std::nullopt};
  std::string s = t.render(h, leader, sim, followers(), m, 1.0);
  EXPECT_EQ(s.substr(0, s.find('\n')), "esfleet fleet: 2 robots, domain 7, 12 s of 60");
  EXPECT_NE(s.find("  leader    97% CPU   100 MB  map: none yet\n"), std::string::npos) << s;
  h.map = MapProgress{12, 300, true};
  h.duration_s = 0.0;
  s = t.render(h, leader, sim, followers(), m, 1.0);
  EXPECT_EQ(s.substr(0, s.find('\n')), "esfleet fleet: 2 robots, domain 7, 12 s");
  EXPECT_NE(s.find("map: 12 tiles, 300 scans, complete\n"), std::string::npos) << s;
}

TEST(StatusTable, RobotLinesShowStateLocalisationErrorAndExits) {
  StatusTable t;
  const FleetMonitor m = monitor_with_poses(3);
  const std::string s = t.render({2, 7, 20.0, 0.0, 5.0, std::nullopt}, {}, {}, followers(), m, 2.0);
  const std::string r1 = line_of(s, "robot-1");
  // Tracking, localised 15 - 5 = 10 s after the followers started, 0.2 m off (within the
  // 0.3 m tolerance: no flag), 42 % CPU, 2 MB, 4 poses in 2 s.
  EXPECT_EQ(r1, "  robot-1    tracking       10.0 s    0.20    0.20     42      2     2.0");
  const std::string r2 = line_of(s, "robot-2");
  EXPECT_NE(r2.find("EXITED"), std::string::npos) << s;
  EXPECT_NE(r2.find("      -       -       -"), std::string::npos) << s;
}

TEST(StatusTable, PosesPerSecondCountSinceTheLastRender) {
  StatusTable t;
  FleetMonitor m = monitor_with_poses(9);  // 10 poses
  const StatusHeader h{2, 7, 20.0, 0.0, 5.0, std::nullopt};
  EXPECT_TRUE(line_of(t.render(h, {}, {}, followers(), m, 2.0), "robot-1").ends_with(" 5.0"));
  for (int i = 0; i < 3; ++i) m.on_pose({"robot-1", 200.0 + i, 1, 0, 0, kStatusTracking}, 21.0);
  EXPECT_TRUE(line_of(t.render(h, {}, {}, followers(), m, 2.0), "robot-1").ends_with(" 1.5"));
  EXPECT_TRUE(line_of(t.render(h, {}, {}, followers(), m, 0.0), "robot-1").ends_with(" 0.0"));
}

TEST(StatusTable, TheLegendExplainsEveryRobotColumnAndTheTolerance) {
  const std::string legend = StatusTable::legend(Tolerance{});
  for (const char* column : {"state", "localised", "err m", "med m", "CPU %", "MB", "poses/s",
                             "WRONG POSE DECLARED", "0.3 m or 5 deg"}) {
    EXPECT_NE(legend.find(column), std::string::npos) << column;
  }
}

TEST(StatusTable, AWrongDeclarationIsFlagged) {
  StatusTable t;
  FleetMonitor m;
  m.add_robot("robot-1");
  m.add_robot("robot-2");
  m.on_truth({"robot-1", 1.0, 5.0, 5.0, 0.0});
  m.on_pose({"robot-1", 1.0, 0.0, 0.0, 0.0, kStatusTracking}, 3.0);  // 7 m off
  const std::string s = t.render({2, 7, 4.0, 0.0, 0.0, std::nullopt}, {}, {}, followers(), m, 1.0);
  EXPECT_NE(line_of(s, "robot-1").find("WRONG POSE DECLARED"), std::string::npos) << s;
  EXPECT_EQ(line_of(s, "robot-2").find("WRONG"), std::string::npos) << s;
}

}  // namespace
}  // namespace esfleet::fleet
