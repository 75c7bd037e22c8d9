// ReplayApp: a bad log or --first-scan fails the constructor naming it; a run publishes every
// scan from --first-scan on, in order, numbered from 0, to a reader in this process (DDS
// domains 186 and 187, shared memory), and a stop before the run sends nothing and ends 130.
// With --ros (domains 188, 189): LaserScans, Odometry and /tf under the namespace with the
// log's stamps, /tf_static with the laser mount, to readers with the QoS of ROS 2 subscribers.
#include "replay_app.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "../dds/dds_test_support.hpp"
#include "app/program.hpp"
#include "esfleet/dds/reader.hpp"
#include "esfleet/dds/ros.hpp"
#include "esfleet/dds/ros_msg.hpp"

namespace esfleet::sim {
namespace {

const std::string kLog = std::string(ESFLEET_TEST_DATA_DIR) + "/carmen/mit-csail-excerpt.clf";
const std::string& kShm = esfleet::test::kShmProfile;

ReplayOptions options(int domain) {
  ReplayOptions o;
  o.log = kLog;
  o.robot_id = "r1";
  o.rate = 0.0;
  o.domain = domain;
  o.profile = kShm;
  o.wait_subscribers = 0;
  return o;
}

std::string construction_error(const ReplayOptions& o) {
  std::atomic<bool> stop{false};
  try {
    ReplayApp app(o, stop);
  } catch (const app::UsageError& e) {
    return e.what();
  }
  return "";
}

TEST(ReplayApp, AMissingLogIsAUsageErrorNamingTheFile) {
  ReplayOptions o = options(186);
  o.log = "/nonexistent/esfleet.log";
  EXPECT_EQ(construction_error(o).rfind("/nonexistent/esfleet.log: cannot open", 0), 0u)
      << construction_error(o);
}

TEST(ReplayApp, FirstScanPastTheEndNamesTheFlag) {
  ReplayOptions o = options(186);
  o.first_scan = 5;  // the excerpt has 5 scans
  EXPECT_EQ(construction_error(o), "--first-scan 5: " + kLog + " has only 5 scans");
  o.max_scans = 3;
  o.first_scan = 3;
  EXPECT_EQ(construction_error(o),
            "--first-scan 3: " + kLog + " has only 3 scans (with --max-scans)");
}

TEST(ReplayApp, PublishesEveryScanFromFirstScanInOrder) {
  dds::Node node({186, kShm, "replay_app_test"});
  std::mutex mutex;
  std::vector<msg::LaserScanMsg> got;
  dds::ScanReader reader(
      node,
      [&](const msg::LaserScanMsg& m, const dds::SampleMeta&) {
        std::lock_guard lock(mutex);
        got.push_back(m);
      },
      "r1");
  ReplayOptions o = options(186);
  o.first_scan = 2;
  o.odometry = false;
  o.wait_subscribers = 1;
  o.wait_timeout = 10.0;
  std::atomic<bool> stop{false};
  ReplayApp app(o, stop);
  ASSERT_EQ(app.scans().size(), 3u);
  EXPECT_EQ(app.run(), app::kExitOk);
  for (int i = 0; i < 100; ++i) {  // acknowledged means received; a margin for the callback
    {
      std::lock_guard lock(mutex);
      if (got.size() >= 3) break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::lock_guard lock(mutex);
  ASSERT_EQ(got.size(), 3u);
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_EQ(got[i].seq(), i);
    EXPECT_EQ(got[i].stamp(), app.scans()[i].stamp);
    EXPECT_EQ(got[i].robot_id().to_string(), "r1");
    EXPECT_FALSE(got[i].has_odometry());  // --odometry off
  }
}

TEST(ReplayApp, StoppedBeforeTheRunSendsNothingAndEndsWith130) {
  std::atomic<bool> stop{false};
  ReplayApp app(options(187), stop);
  stop = true;
  EXPECT_EQ(app.run(), app::kExitInterrupted);
}

template <class Msg>
struct Inbox {
  std::mutex mutex;
  std::vector<Msg> samples;
  typename dds::Reader<Msg>::Callback callback() {
    return [this](const Msg& m, const dds::SampleMeta&) {
      std::lock_guard lock(mutex);
      samples.push_back(m);
    };
  }
  std::size_t size() {
    std::lock_guard lock(mutex);
    return samples.size();
  }
};

using esfleet::test::wait_until;

TEST(ReplayApp, RosModePublishesScansOdometryAndTfWithTheLogsStamps) {
  dds::Node node({188, kShm, "ros_peer"});
  // The QoS of ROS 2 subscribers (ros.hpp: sensor data best-effort for scans and odometry).
  Inbox<sensor_msgs::msg::LaserScan> scans;
  Inbox<nav_msgs::msg::Odometry> odoms;
  Inbox<tf2_msgs::msg::TFMessage> tfs;
  dds::RosScanReader scan_reader(node, scans.callback(),
                                 dds::ros_scan_endpoint("/robot1/scan", true));
  dds::RosOdomReader odom_reader(node, odoms.callback(),
                                 dds::ros_odom_endpoint("/robot1/odom", true));
  dds::RosTfReader tf_reader(node, tfs.callback(), dds::ros_tf_endpoint());
  Inbox<tf2_msgs::msg::TFMessage> statics;
  dds::RosTfReader static_reader(node, statics.callback(), dds::ros_tf_static_endpoint(true));
  EXPECT_EQ(scan_reader.topic_name(), "rt/robot1/scan");
  EXPECT_EQ(odom_reader.topic_name(), "rt/robot1/odom");

  ReplayOptions o = options(188);
  o.robot_id = "robot1";
  o.ros = true;
  o.laser_pose = Pose2{0.25, -0.5, 0.125};
  o.wait_subscribers = 1;
  o.wait_timeout = 10.0;
  o.rate = 20.0;  // 5 scans over 0.85 s of log: spaced, not a burst
  ASSERT_EQ(o.ros_ns(), "/robot1");
  std::atomic<bool> stop{false};
  ReplayApp app(o, stop);
  const std::vector<LaserScan> log = app.scans();
  ASSERT_EQ(log.size(), 5u);
  // The odometry and tf readers must be matched too before the run (only the scan readers are
  // waited for): they are in the same participant, discovered at once.
  EXPECT_TRUE(odom_reader.wait_for_matched(1, std::chrono::milliseconds(5000)));
  EXPECT_TRUE(tf_reader.wait_for_matched(1, std::chrono::milliseconds(5000)));
  EXPECT_TRUE(static_reader.wait_for_matched(1, std::chrono::milliseconds(5000)));
  EXPECT_EQ(app.run(), app::kExitOk);
  ASSERT_TRUE(
      wait_until([&] { return scans.size() >= 5 && odoms.size() >= 5 && tfs.size() >= 5; }));

  ASSERT_TRUE(wait_until([&] { return statics.size() >= 1; }));

  std::scoped_lock lock(scans.mutex, odoms.mutex, tfs.mutex, statics.mutex);
  ASSERT_EQ(scans.samples.size(), 5u);
  ASSERT_EQ(odoms.samples.size(), 5u);
  ASSERT_EQ(tfs.samples.size(), 5u);
  for (std::size_t i = 0; i < log.size(); ++i) {
    const sensor_msgs::msg::LaserScan& m = scans.samples[i];
    EXPECT_EQ(m.header().frame_id(), "robot1/laser");
    const LaserScan got = dds::scan_from_ros(m);
    EXPECT_EQ(got.stamp, log[i].stamp) << i;  // the log's time, not the wall clock
    // The same readings; no-returns (the log has 81.91 m beyond its 81.9 m maximum) come back
    // at range_max.
    ASSERT_EQ(got.ranges.size(), log[i].ranges.size());
    std::size_t no_returns = 0;
    for (std::size_t b = 0; b < got.ranges.size(); ++b) {
      no_returns += log[i].is_no_return(b);
      EXPECT_EQ(got.ranges[b], log[i].is_no_return(b) ? log[i].max_range : log[i].ranges[b]) << b;
      EXPECT_EQ(got.is_no_return(b), log[i].is_no_return(b)) << b;
    }
    EXPECT_GT(no_returns, 0u);
    EXPECT_EQ(got.angle_min, log[i].angle_min);
    EXPECT_EQ(got.angle_increment, log[i].angle_increment);
    EXPECT_EQ(got.max_range, log[i].max_range);

    ASSERT_TRUE(log[i].odometry.has_value());
    const nav_msgs::msg::Odometry& od = odoms.samples[i];
    EXPECT_EQ(od.header().frame_id(), "robot1/odom");
    EXPECT_EQ(od.child_frame_id(), "robot1/base_link");
    EXPECT_EQ(od.header().stamp(), m.header().stamp());
    const TimedPose pose = dds::odom_from_ros(od);
    EXPECT_EQ(pose.stamp, log[i].stamp);
    EXPECT_EQ(pose.pose.x, log[i].odometry->x);
    EXPECT_EQ(pose.pose.y, log[i].odometry->y);
    EXPECT_NEAR(normalize_angle(pose.pose.theta - log[i].odometry->theta), 0.0, 1e-12);

    ASSERT_EQ(tfs.samples[i].transforms().size(), 1u);
    const geometry_msgs::msg::TransformStamped& t = tfs.samples[i].transforms().front();
    EXPECT_EQ(t.header().frame_id(), "robot1/odom");
    EXPECT_EQ(t.child_frame_id(), "robot1/base_link");
    EXPECT_EQ(t.header().stamp(), m.header().stamp());
    EXPECT_EQ(t.transform().translation().x(), od.pose().pose().position().x());
    EXPECT_EQ(t.transform().translation().y(), od.pose().pose().position().y());
    EXPECT_EQ(t.transform().rotation(), od.pose().pose().orientation());
  }
  ASSERT_EQ(statics.samples.size(), 1u);
  ASSERT_EQ(statics.samples[0].transforms().size(), 1u);
  const geometry_msgs::msg::TransformStamped& mount = statics.samples[0].transforms().front();
  EXPECT_EQ(mount.header().frame_id(), "robot1/base_link");
  EXPECT_EQ(mount.child_frame_id(), "robot1/laser");
  EXPECT_EQ(mount.header().stamp(), scans.samples[0].header().stamp());  // the first log stamp
  const Pose2 p = dds::pose2_from_ros(mount.transform());
  EXPECT_EQ(p.x, 0.25);
  EXPECT_EQ(p.y, -0.5);
  EXPECT_NEAR(p.theta, 0.125, 1e-12);
}

TEST(ReplayApp, RosModeWithoutOdometryOrNamespaceSendsScansOnly) {
  dds::Node node({189, kShm, "ros_peer"});
  Inbox<sensor_msgs::msg::LaserScan> scans;
  Inbox<nav_msgs::msg::Odometry> odoms;
  Inbox<tf2_msgs::msg::TFMessage> tfs;
  dds::RosScanReader scan_reader(node, scans.callback(), dds::ros_scan_endpoint("/scan", true));
  dds::RosOdomReader odom_reader(node, odoms.callback(), dds::ros_odom_endpoint("/odom", true));
  dds::RosTfReader tf_reader(node, tfs.callback(), dds::ros_tf_endpoint());
  ReplayOptions o = options(189);
  o.ros = true;
  o.ros_namespace = "/";
  o.laser_frame = "base_scan";
  o.odometry = false;
  o.first_scan = 3;
  o.wait_subscribers = 1;
  o.wait_timeout = 10.0;
  std::atomic<bool> stop{false};
  ReplayApp app(o, stop);
  // The replay waits until its writer has matched the reader; a best-effort reader drops what
  // comes before it has matched the writer in turn, which under load can be later.
  ASSERT_TRUE(scan_reader.wait_for_matched(1, std::chrono::milliseconds(5000)));
  EXPECT_EQ(app.run(), app::kExitOk);
  ASSERT_TRUE(wait_until([&] { return scans.size() >= 2; }));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  std::scoped_lock lock(scans.mutex, odoms.mutex, tfs.mutex);
  ASSERT_EQ(scans.samples.size(), 2u);
  EXPECT_EQ(scans.samples[0].header().frame_id(), "base_scan");
  EXPECT_EQ(dds::seconds_of(scans.samples[1].header().stamp()), app.scans()[1].stamp);
  EXPECT_EQ(odom_reader.matched_writers(), 0);  // no odometry writer at all
  EXPECT_TRUE(odoms.samples.empty());
  EXPECT_TRUE(tfs.samples.empty());
}

}  // namespace
}  // namespace esfleet::sim
