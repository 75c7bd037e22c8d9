// The ROS 2 types over real Fast DDS between two Nodes of one process (shared memory): a
// LaserScan on a robot's ROS scan topic with the writer's and the reader's QoS of ros.hpp
// arrives equal, on DDS topic "rt/robot1/scan"; an OccupancyGrid written on "rt/map"
// (reliable, transient-local, depth 1) reaches a reader that joins after it was written, and
// only the newest one does. Domains 115 and 116 (tests/dds/CMakeLists.txt).

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "dds_test_support.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/ros.hpp"
#include "esfleet/dds/ros_msg.hpp"

namespace esfleet::dds {
namespace {

using std::chrono::milliseconds;

const std::string& kShm = esfleet::test::kShmProfile;

using esfleet::test::wait_until;

template <class Msg>
struct Inbox {
  std::mutex mutex;
  std::vector<Msg> samples;
  typename Reader<Msg>::Callback callback() {
    return [this](const Msg& m, const SampleMeta&) {
      std::lock_guard lock(mutex);
      samples.push_back(m);
    };
  }
  std::size_t size() {
    std::lock_guard lock(mutex);
    return samples.size();
  }
};

TEST(RosWriterReader, ScanOnARobotsScanTopicArrivesEqual) {
  Node robot({115, kShm, "ros_scan_writer"});
  Node peer({115, kShm, "ros_scan_reader"});
  Inbox<sensor_msgs::msg::LaserScan> inbox;
  const std::string name = ros_name("/robot1", "scan");
  RosScanReader reader(peer, inbox.callback(), ros_scan_endpoint(name, true));
  RosScanWriter writer(robot, ros_scan_endpoint(name, false));
  EXPECT_EQ(writer.topic_name(), "rt/robot1/scan");
  EXPECT_EQ(reader.topic_name(), "rt/robot1/scan");
  // Reliable writer, best-effort reader: they match (the reader asks for less).
  ASSERT_TRUE(writer.wait_for_matched(1, milliseconds(5000)));
  ASSERT_TRUE(reader.wait_for_matched(1, milliseconds(5000)));

  LaserScan s;
  s.stamp = 1'100'000'321.125;
  s.angle_min = -1.5707964f;
  s.angle_increment = 0.017453292f;
  s.max_range = 81.9f;
  for (int i = 0; i < 180; ++i)
    s.ranges.push_back(i % 10 == 0 ? 81.9f : 0.25f * static_cast<float>(i));
  sensor_msgs::msg::LaserScan m = scan_to_ros(s, "robot1/laser");
  m.intensities(std::vector<float>(180, 0.5f));
  m.scan_time(0.2f);
  ASSERT_TRUE(writer.write(m));
  ASSERT_TRUE(wait_until([&] { return inbox.size() >= 1; }));
  EXPECT_TRUE(writer.wait_for_acknowledgments(milliseconds(2000)));

  std::lock_guard lock(inbox.mutex);
  ASSERT_EQ(inbox.samples.size(), 1u);
  const sensor_msgs::msg::LaserScan& got = inbox.samples.front();
  EXPECT_EQ(got, m);  // every field, the generated operator==
  EXPECT_EQ(got.header().frame_id(), "robot1/laser");
  EXPECT_EQ(got.header().stamp().sec(), 1'100'000'321);
  EXPECT_EQ(got.header().stamp().nanosec(), 125'000'000u);
  EXPECT_EQ(got.ranges(), s.ranges);
  EXPECT_EQ(got.intensities().size(), 180u);
  const LaserScan back = scan_from_ros(got);
  EXPECT_EQ(back.stamp, s.stamp);
  EXPECT_EQ(back.ranges, s.ranges);
  EXPECT_EQ(reader.samples_received(), 1u);
  EXPECT_EQ(reader.bytes_received(), writer.bytes_written());
  EXPECT_GT(writer.bytes_written(), 180u * 4u * 2u);
}

TEST(RosWriterReader, LateTransientLocalReaderGetsTheNewestMap) {
  Node leader({116, kShm, "ros_map_writer"});
  RosMapWriter writer(leader, ros_map_endpoint());
  EXPECT_EQ(writer.topic_name(), "rt/map");

  GridMapConfig c;
  c.cell_size = 0.05;
  c.tile_edge = 8;
  GridMap map(c);
  map.add_hit({-1, -1});
  map.commit_update();
  const nav_msgs::msg::OccupancyGrid first = grid_to_ros(map, map_window(map), {}, 1.0, "map");
  map.add_err({3, 12});
  map.commit_update();
  const nav_msgs::msg::OccupancyGrid newest = grid_to_ros(map, map_window(map), {}, 2.0, "map");
  ASSERT_NE(first.info().height(), newest.info().height());
  ASSERT_TRUE(writer.write(first));
  ASSERT_TRUE(writer.write(newest));

  // The reader joins after both were written.
  Node viewer({116, kShm, "ros_map_reader"});
  Inbox<nav_msgs::msg::OccupancyGrid> inbox;
  RosMapReader reader(viewer, inbox.callback(), ros_map_endpoint());
  EXPECT_EQ(reader.topic_name(), "rt/map");
  ASSERT_TRUE(wait_until([&] { return inbox.size() >= 1; }));
  std::this_thread::sleep_for(milliseconds(300));  // nothing more comes
  std::lock_guard lock(inbox.mutex);
  ASSERT_EQ(inbox.samples.size(), 1u);  // KEEP_LAST 1: the newest only
  EXPECT_EQ(inbox.samples.front(), newest);
  EXPECT_EQ(inbox.samples.front().info().width(), 16u);
  EXPECT_EQ(inbox.samples.front().info().height(), 24u);
  EXPECT_EQ(inbox.samples.front().header().stamp().sec(), 2);
}

}  // namespace
}  // namespace esfleet::dds
