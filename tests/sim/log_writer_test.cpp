// --out-log round trip: the CARMEN log a simulated robot writes reads back with core's
// CarmenReader (scans, no-returns, odometry, stamps) and its truth file with trajectory_io.

#include "esfleet/sim/log_writer.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/trajectory_io.hpp"
#include "esfleet/sim/fleet.hpp"
#include "sim_test_world.hpp"

namespace esfleet::sim {
namespace {

/// A fresh scratch directory, removed at the end of the test.
struct ScratchDir {
  std::filesystem::path path;
  ScratchDir() {
    path = std::filesystem::temp_directory_path() /
           ("esfleet-sim-log-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(path);
    std::filesystem::create_directories(path);
  }
  ~ScratchDir() { std::filesystem::remove_all(path); }
};

/// Runs `config` for `ticks` ticks writing the logs; returns the samples per robot.
std::vector<std::vector<RobotSample>> run(const World& world, const FleetConfig& config, int ticks,
                                          const std::string& dir) {
  Fleet fleet(world, config);
  std::vector<RobotLogWriter> writers;
  for (const auto& r : fleet.robots()) writers.emplace_back(dir, r.id());
  std::vector<std::vector<RobotSample>> out(fleet.robots().size());
  for (int k = 0; k < ticks; ++k) {
    const auto& samples = fleet.tick();
    for (std::size_t i = 0; i < samples.size(); ++i) {
      writers[i].write(samples[i].scan, samples[i].truth.pose, samples[i].robot->speed(),
                       samples[i].robot->turn_rate());
      out[i].push_back(samples[i]);
    }
  }
  for (auto& w : writers) w.flush();
  return out;
}

void expect_round_trip(const std::vector<RobotSample>& sent, const std::string& log,
                       const std::string& truth) {
  CarmenReader reader(log);
  std::vector<LaserScan> scans;
  while (auto s = reader.next_scan()) scans.push_back(std::move(*s));
  ASSERT_EQ(scans.size(), sent.size());
  EXPECT_EQ(reader.odom_messages(), sent.size());
  int no_returns = 0;
  for (std::size_t k = 0; k < sent.size(); ++k) {
    const LaserScan& a = sent[k].scan;
    const LaserScan& b = scans[k];
    EXPECT_NEAR(b.stamp, a.stamp, 1e-6);
    EXPECT_NEAR(b.angle_min, a.angle_min, 1e-6);
    EXPECT_NEAR(b.angle_increment, a.angle_increment, 1e-6);
    ASSERT_EQ(b.ranges.size(), a.ranges.size());
    for (std::size_t i = 0; i < a.ranges.size(); ++i) {
      ASSERT_EQ(b.is_no_return(i), a.is_no_return(i)) << "scan " << k << " beam " << i;
      if (a.is_no_return(i)) {
        ++no_returns;
      } else {
        ASSERT_NEAR(b.ranges[i], a.ranges[i], 0.5e-4 + 1e-6);
      }
    }
    ASSERT_TRUE(b.odometry.has_value());
    EXPECT_NEAR(b.odometry->x, a.odometry->x, 1e-6);
    EXPECT_NEAR(b.odometry->y, a.odometry->y, 1e-6);
    EXPECT_NEAR(b.odometry->theta, a.odometry->theta, 1e-6);
  }
  EXPECT_GT(no_returns, 0);  // dropouts at least

  const std::vector<TimedPose> poses = read_trajectory(truth);
  ASSERT_EQ(poses.size(), sent.size());
  for (std::size_t k = 0; k < sent.size(); ++k) {
    // Same text for the stamp in both files: the stamps pair up exactly.
    EXPECT_EQ(poses[k].stamp, scans[k].stamp);
    EXPECT_NEAR(poses[k].pose.x, sent[k].truth.pose.x, 1e-6);
    EXPECT_NEAR(poses[k].pose.y, sent[k].truth.pose.y, 1e-6);
    EXPECT_NEAR(poses[k].pose.theta, sent[k].truth.pose.theta, 1e-6);
  }
}

TEST(RobotLogWriter, FlaserLogAndTruthReadBack) {
  const World world(testing::two_rooms());
  ScratchDir dir;
  FleetConfig c;
  c.robots = 2;
  c.start_stamp = 1700000000.0;
  c.laser.max_range = 4.0;  // some beams see no wall
  const auto sent = run(world, c, 60, dir.path.string());
  for (std::size_t i = 0; i < sent.size(); ++i) {
    const std::string id = "robot-" + std::to_string(i + 1);
    expect_round_trip(sent[i], (dir.path / (id + ".log")).string(),
                      (dir.path / (id + ".truth")).string());
  }
}

TEST(RobotLogWriter, OtherLayoutsUseRobotLaser1) {
  const World world(testing::two_rooms());
  ScratchDir dir;
  FleetConfig c;
  c.laser.beams = 270;
  c.laser.fov_deg = 270.0;
  c.laser.max_range = 5.0;
  c.start_stamp = 50.0;
  const auto sent = run(world, c, 30, dir.path.string());
  expect_round_trip(sent[0], (dir.path / "robot-1.log").string(),
                    (dir.path / "robot-1.truth").string());
}

TEST(RobotLogWriter, UnwritableDirectoryNamesTheFile) {
  try {
    RobotLogWriter w("/nonexistent-dir-esfleet", "r1");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir-esfleet/r1.log"), std::string::npos);
  }
}

}  // namespace
}  // namespace esfleet::sim
