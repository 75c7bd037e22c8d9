// The launcher's summary.json: per-robot entries merged from the monitor and the follower's
// stats.json, the real-time rule, and the fleet's totals.
#include "fleet_summary.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace esfleet::fleet {
namespace {

namespace fs = std::filesystem;

/// robot-1 declared a right pose at 20 s and tracked `poses` scans of `truths` in the window;
/// robot-2 never localised.
FleetMonitor monitor(std::size_t truths, std::size_t poses) {
  FleetMonitor m;
  m.add_robot("robot-1");
  m.add_robot("robot-2");
  m.on_truth({"robot-1", 1.0, 1.0, 2.0, 0.0});
  m.on_pose({"robot-1", 1.0, 1.1, 2.0, 0.0, kStatusTracking}, 20.0);
  m.start_window();
  for (std::size_t i = 0; i < truths; ++i) {
    const double stamp = 10.0 + static_cast<double>(i);
    m.on_truth({"robot-1", stamp, 1.0, 2.0, 0.0});
    if (i < poses) m.on_pose({"robot-1", stamp, 1.0, 2.0, 0.0, kStatusTracking}, 30.0);
  }
  return m;
}

std::vector<ChildProcess> followers() {
  std::vector<ChildProcess> f(2);
  f[0].name = "robot-1";
  f[0].pid = 100;
  f[1].name = "robot-2";  // never started
  return f;
}

nlohmann::json stats(double lag_p95_ms) {
  return {{"bytes_received", 1234},
          {"tiles", 56},
          {"localisation", {{"scans", 300}, {"tracking_lag_ms_p95", lag_p95_ms}}}};
}

TEST(FleetSummary, FollowerEntryMergesMonitorAndStats) {
  const FleetMonitor m = monitor(100, 100);
  const FleetTimes t{80.0, 5.0, 30.0};
  const nlohmann::json j =
      follower_summary(followers()[0], m.robots().at("robot-1"), stats(50.0), t, 5.0);
  EXPECT_EQ(j["robot_id"], "robot-1");
  EXPECT_EQ(j["final_state"], "tracking");
  EXPECT_EQ(j["localised"], true);
  EXPECT_DOUBLE_EQ(j["time_to_localise_s"].get<double>(), 15.0);
  EXPECT_NEAR(j["first_pose_error_m"].get<double>(), 0.1, 1e-9);
  EXPECT_EQ(j["bytes_received"], 1234);
  EXPECT_EQ(j["map_tiles"], 56);
  EXPECT_EQ(j["scans_processed"], 300);
  EXPECT_EQ(j["scans_dropped"], 0);  // absent from stats: 0
  EXPECT_EQ(j["window_scans"], 100);
  EXPECT_EQ(j["exit_code"], 0);
  EXPECT_EQ(j["started"], true);
  EXPECT_EQ(j["realtime"], true);
}

TEST(FleetSummary, RealTimeNeedsTenSecondsAllScansAndLagBelowAPeriod) {
  const FleetTimes t{80.0, 5.0, 30.0};  // a 50 s window
  const auto rt = [&](const FleetMonitor& m, double lag, const FleetTimes& times) {
    return follower_summary(followers()[0], m.robots().at("robot-1"), stats(lag), times, 5.0)
        .at("realtime")
        .get<bool>();
  };
  EXPECT_TRUE(rt(monitor(100, 98), 199.0, t));    // 98 %, lag under 200 ms (5 Hz)
  EXPECT_FALSE(rt(monitor(100, 97), 10.0, t));    // 97 % of the scans
  EXPECT_FALSE(rt(monitor(100, 100), 200.0, t));  // lag p95 of a whole period
  EXPECT_FALSE(rt(monitor(100, 100), 10.0, FleetTimes{39.0, 5.0, 30.0}));  // 9 s window
  EXPECT_FALSE(rt(monitor(100, 100), 10.0, FleetTimes{80.0, 5.0, -1.0}));  // no window
}

TEST(FleetSummary, ARobotNeverStartedOrLocalised) {
  const FleetMonitor m = monitor(0, 0);
  const nlohmann::json j = follower_summary(followers()[1], m.robots().at("robot-2"),
                                            nlohmann::json::object(), FleetTimes{}, 5.0);
  EXPECT_EQ(j["localised"], false);
  EXPECT_EQ(j["time_to_localise_s"], -1.0);
  EXPECT_EQ(j["first_pose_error_m"], -1.0);
  EXPECT_EQ(j["final_state"], "-");
  EXPECT_EQ(j["started"], false);
  EXPECT_EQ(j["exit_code"], -1);
  EXPECT_EQ(j["cpu_percent_window"], -1.0);
  EXPECT_EQ(j["bytes_received"], 0);
}

TEST(FleetSummary, TotalsAndTheRunsFigures) {
  FleetOptions o;
  o.robots = 2;
  o.domain = 9;
  o.seed = 3;
  ChildProcess leader, sim;
  leader.exit_code = 0;
  sim.exit_code = 130;
  const FleetMonitor m = monitor(100, 100);
  const FleetSummary s =
      build_summary(o, FleetTimes{80.0, 5.0, 30.0}, "robot-2 exited early", leader, sim,
                    followers(), m, {stats(50.0), nlohmann::json::object()});
  EXPECT_EQ(s.localised, 1);
  EXPECT_EQ(s.realtime, 1);
  EXPECT_EQ(s.wrong, 0);
  EXPECT_EQ(s.json["robots"], 2);
  EXPECT_EQ(s.json["all_localised"], false);
  EXPECT_EQ(s.json["all_realtime"], false);
  EXPECT_EQ(s.json["failure"], "robot-2 exited early");
  EXPECT_DOUBLE_EQ(s.json["window_s"].get<double>(), 50.0);
  EXPECT_DOUBLE_EQ(s.json["all_tracking_s"].get<double>(), 25.0);
  EXPECT_EQ(s.json["sim"]["exit_code"], 130);
  EXPECT_EQ(s.json["seed"], 3);
  ASSERT_EQ(s.json["followers"].size(), 2u);
  EXPECT_EQ(s.json["followers"][1]["robot_id"], "robot-2");
  EXPECT_EQ(summary_line(s, 2, "x/summary.json"),
            "fleet of 2: 1 localised, 1 in real time, 0 with a wrong pose; summary "
            "x/summary.json");
}

TEST(FleetSummary, StatsOfAFollowerThatWroteNoneOrGarbageAreEmpty) {
  const fs::path dir =
      fs::temp_directory_path() / ("esfleet-fleet-summary-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  EXPECT_EQ(read_stats_json((dir / "missing.json").string()), nlohmann::json::object());
  std::ofstream(dir / "bad.json") << "{\"tiles\": ";
  EXPECT_EQ(read_stats_json((dir / "bad.json").string()), nlohmann::json::object());
  std::ofstream(dir / "good.json") << "{\"tiles\": 4}";
  EXPECT_EQ(read_stats_json((dir / "good.json").string())["tiles"], 4);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace esfleet::fleet
