// The dds ROS layer without DDS entities: ROS names, frames and DDS topic names with ROS 2's
// naming rules (ros.hpp), the QoS of each ROS endpoint, and the conversions of ros_msg.hpp:
// scans bit for bit both ways and every refusal kind, poses / odometry / transforms through the
// quaternion, pose hints from the covariance, ROS time, and the occupancy grid window, data and
// updates of a small GridMap.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "esfleet/dds/ros.hpp"
#include "esfleet/dds/ros_msg.hpp"

namespace esfleet::dds {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

/// The what() of the RosNameError that `f` throws ("" if it throws none).
std::string name_error(const std::function<void()>& f) {
  try {
    f();
  } catch (const RosNameError& e) {
    return e.what();
  }
  return "";
}

/// The kind() of the RosMessageError that `f` throws ("" if it throws none).
std::string refusal(const std::function<void()>& f) {
  try {
    f();
  } catch (const RosMessageError& e) {
    EXPECT_NE(std::string(e.what()), "");
    return e.kind();
  }
  return "";
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// ---------------------------------------------------------------------------------------------
// Names, frames, topics and endpoints

TEST(RosNames, RelativeNamesGoUnderTheNamespaceAbsoluteOnesStay) {
  EXPECT_EQ(ros_name("", "scan"), "/scan");
  EXPECT_EQ(ros_name("/", "scan"), "/scan");
  EXPECT_EQ(ros_name("/robot1", "scan"), "/robot1/scan");
  EXPECT_EQ(ros_name("robot1", "scan"), "/robot1/scan");
  EXPECT_EQ(ros_name("/fleet/robot_2", "base/scan"), "/fleet/robot_2/base/scan");
  EXPECT_EQ(ros_name("/robot1", "/map"), "/map");
  EXPECT_EQ(ros_name("", "/tf_static"), "/tf_static");
  EXPECT_EQ(ros_name("/", "/a/b_2"), "/a/b_2");
  EXPECT_EQ(ros_name("/Robot_1", "_scan9"), "/Robot_1/_scan9");
}

TEST(RosNames, BrokenNamesAndNamespacesAreRefusedNamingThem) {
  struct Case {
    std::string ns, name, named;
  };
  const std::vector<Case> cases = {
      {"/robot1", "a//b", "'a//b'"},       // empty token
      {"/robot1", "scan/", "'scan/'"},     // trailing '/'
      {"/robot1", "2scan", "'2scan'"},     // token starting with a digit
      {"/robot1", "a/9b", "'a/9b'"},       // a later token starting with a digit
      {"/robot1", "a-b", "'a-b'"},         // bad character
      {"/robot1", "~x", "'~x'"},           // private names are not supported
      {"/robot1", "sc an", "'sc an'"},     // space
      {"/robot1", "", "''"},               // empty
      {"/robot1", "/", "'/'"},             // the root alone is no topic name
      {"/robot1", "//map", "'//map'"},     // empty first token
      {"/robot1/", "scan", "'/robot1/'"},  // namespace with a trailing '/'
      {"/robot-1", "scan", "'/robot-1'"},  // namespace with a bad character
      {"/1robot", "scan", "'/1robot'"},    // namespace token starting with a digit
      {"/a//b", "scan", "'/a//b'"},        // namespace with an empty token
      {"~", "scan", "'~'"},                // namespace of bad characters
  };
  for (const Case& c : cases) {
    const std::string what = name_error([&] { ros_name(c.ns, c.name); });
    EXPECT_TRUE(has(what, c.named)) << "ns '" << c.ns << "' name '" << c.name << "': " << what;
    EXPECT_TRUE(has(what, "ROS ")) << what;
  }
  // A RosNameError is an invalid_argument (the programs report it as a usage error).
  EXPECT_THROW(ros_name("", "a-b"), std::invalid_argument);
}

TEST(RosNames, FramesGoUnderTheNamespaceWithoutLeadingSlash) {
  EXPECT_EQ(ros_frame("/robot1", "odom"), "robot1/odom");
  EXPECT_EQ(ros_frame("robot1", "odom"), "robot1/odom");
  EXPECT_EQ(ros_frame("/fleet/robot1", "base_link"), "fleet/robot1/base_link");
  EXPECT_EQ(ros_frame("/", "odom"), "odom");
  EXPECT_EQ(ros_frame("", "laser"), "laser");
}

TEST(RosNames, DdsTopicIsRtPlusTheName) {
  EXPECT_EQ(ros_dds_topic("/map"), "rt/map");
  EXPECT_EQ(ros_dds_topic("/robot1/scan"), "rt/robot1/scan");
  EXPECT_EQ(ros_dds_topic(ros_name("/robot1", "odom")), "rt/robot1/odom");
}

void expect_endpoint(const TopicQos& e, const std::string& topic, bool reliable,
                     bool transient_local, std::int32_t depth) {
  EXPECT_EQ(e.topic, topic);
  EXPECT_EQ(e.reliable, reliable) << topic;
  EXPECT_EQ(e.transient_local, transient_local) << topic;
  EXPECT_EQ(e.depth, depth) << topic;
}

TEST(RosEndpoints, TopicAndQosAsTheRosToolsUseThem) {
  expect_endpoint(ros_map_endpoint(), "rt/map", true, true, 1);
  expect_endpoint(ros_map_updates_endpoint(), "rt/map_updates", true, false, 16);
  expect_endpoint(ros_pose_endpoint("/robot1/pose"), "rt/robot1/pose", true, true, 1);
  expect_endpoint(ros_initialpose_endpoint("/robot1/initialpose"), "rt/robot1/initialpose", true,
                  false, 1);
  expect_endpoint(ros_tf_endpoint(), "rt/tf", true, false, 100);
  expect_endpoint(ros_tf_static_endpoint(false), "rt/tf_static", true, true, 1);
  expect_endpoint(ros_tf_static_endpoint(true), "rt/tf_static", true, true, 100);
  expect_endpoint(ros_scan_endpoint("/robot1/scan", false), "rt/robot1/scan", true, false, 50);
  expect_endpoint(ros_scan_endpoint("/robot1/scan", true), "rt/robot1/scan", false, false, 5);
  expect_endpoint(ros_odom_endpoint("/robot1/odom", false), "rt/robot1/odom", true, false, 50);
  expect_endpoint(ros_odom_endpoint("/robot1/odom", true), "rt/robot1/odom", false, false, 50);
}

// ---------------------------------------------------------------------------------------------
// Time

TEST(RosTime, SecondsToTimeAndBack) {
  EXPECT_EQ(ros_time(0.0).sec(), 0);
  EXPECT_EQ(ros_time(0.0).nanosec(), 0u);
  EXPECT_EQ(ros_time(1.5).sec(), 1);
  EXPECT_EQ(ros_time(1.5).nanosec(), 500'000'000u);
  EXPECT_EQ(ros_time(2.000000001).sec(), 2);
  EXPECT_EQ(ros_time(2.000000001).nanosec(), 1u);
  EXPECT_EQ(ros_time(1.9999999994).sec(), 1);
  EXPECT_EQ(ros_time(1.9999999994).nanosec(), 999'999'999u);
  // Fractions that round up to a whole second carry into sec, never nanosec == 1e9.
  EXPECT_EQ(ros_time(1.9999999996).sec(), 2);
  EXPECT_EQ(ros_time(1.9999999996).nanosec(), 0u);
  const auto big = ros_time(1e9 + 0.999999999);
  EXPECT_LT(big.nanosec(), 1'000'000'000u);
  EXPECT_EQ(static_cast<double>(big.sec()) + big.nanosec() * 1e-9, 1e9 + 0.999999999);
  EXPECT_EQ(big.sec(), 1'000'000'001);  // 1e9 + 0.999999999 is the double 1000000001.0
  EXPECT_EQ(big.nanosec(), 0u);
  // A CARMEN stamp (Unix time, microseconds).
  const auto carmen = ros_time(1'100'000'000.123456);
  EXPECT_EQ(carmen.sec(), 1'100'000'000);
  EXPECT_NEAR(carmen.nanosec(), 123'456'000.0, 200.0);  // the double holds ~0.2 us
  EXPECT_EQ(seconds_of(carmen), 1'100'000'000.123456);
  for (double bad : {-1.0, -1e-9, std::nan(""), std::numeric_limits<double>::infinity(),
                     -std::numeric_limits<double>::infinity()}) {
    EXPECT_EQ(ros_time(bad).sec(), 0) << bad;
    EXPECT_EQ(ros_time(bad).nanosec(), 0u) << bad;
  }

  builtin_interfaces::msg::Time t;
  t.sec(7);
  t.nanosec(250'000'000);
  EXPECT_EQ(seconds_of(t), 7.25);
  t.nanosec(999'999'999);
  EXPECT_NEAR(seconds_of(t), 8.0 - 1e-9, 1e-15);
  t.nanosec(1'000'000'000);
  EXPECT_EQ(refusal([&] { seconds_of(t); }), "bad_stamp");
  // Found by fuzz_ros_msg (fuzz/corpus/fuzz_ros_msg/regress-negative-stamp): ROS 2 times are
  // never negative.
  t.sec(-1);
  t.nanosec(0);
  EXPECT_EQ(refusal([&] { seconds_of(t); }), "bad_stamp");
}

// ---------------------------------------------------------------------------------------------
// Scans

/// A FLASER-like scan: 180 beams over 180 degrees from -pi/2, no-returns at 81.9 m.
LaserScan flaser_scan() {
  LaserScan s;
  s.stamp = 1'100'000'123.456789;
  s.angle_min = static_cast<float>(-kPi / 2);
  s.angle_increment = static_cast<float>(kPi / 180);
  s.max_range = 81.9f;
  for (int i = 0; i < 180; ++i) s.ranges.push_back(0.5f + 0.037f * static_cast<float>(i));
  s.ranges[0] = 81.9f;
  s.ranges[17] = 81.9f;
  s.ranges[179] = 81.9f;
  s.ranges[90] = 0.0f;
  return s;
}

void expect_same_bits(float a, float b, const std::string& what) {
  std::uint32_t ua = 0, ub = 0;
  std::memcpy(&ua, &a, sizeof a);
  std::memcpy(&ub, &b, sizeof b);
  EXPECT_EQ(ua, ub) << what << ": " << a << " vs " << b;
}

void expect_same_scan(const LaserScan& back, const LaserScan& s, double stamp_tolerance) {
  EXPECT_NEAR(back.stamp, s.stamp, stamp_tolerance);
  expect_same_bits(back.angle_min, s.angle_min, "angle_min");
  expect_same_bits(back.angle_increment, s.angle_increment, "angle_increment");
  expect_same_bits(back.max_range, s.max_range, "max_range");
  ASSERT_EQ(back.ranges.size(), s.ranges.size());
  for (std::size_t i = 0; i < s.ranges.size(); ++i) {
    expect_same_bits(back.ranges[i], s.ranges[i], "range " + std::to_string(i));
    EXPECT_EQ(back.is_no_return(i), s.is_no_return(i)) << i;
  }
  EXPECT_FALSE(back.odometry.has_value());
}

TEST(RosScan, FlaserScanRoundTripsBitForBit) {
  const LaserScan s = flaser_scan();
  const sensor_msgs::msg::LaserScan m = scan_to_ros(s, "robot1/laser");
  EXPECT_EQ(m.header().frame_id(), "robot1/laser");
  EXPECT_EQ(m.header().stamp().sec(), 1'100'000'123);
  EXPECT_NEAR(m.header().stamp().nanosec(), 456'789'000.0, 200.0);
  EXPECT_EQ(m.angle_min(), s.angle_min);
  EXPECT_EQ(m.angle_increment(), s.angle_increment);
  EXPECT_EQ(m.angle_max(), s.angle(179));
  EXPECT_NEAR(m.angle_max(), kPi / 2 - kPi / 180, 1e-5);
  EXPECT_EQ(m.range_min(), 0.0f);
  EXPECT_EQ(m.range_max(), 81.9f);
  EXPECT_EQ(m.ranges(), s.ranges);
  // A Unix-time stamp comes back as the same double (its precision is ~0.2 us, far above 1 ns).
  const LaserScan back = scan_from_ros(m);
  expect_same_scan(back, s, 0.0);
  EXPECT_TRUE(back.is_no_return(0));
  EXPECT_TRUE(back.is_no_return(17));
  EXPECT_FALSE(back.is_no_return(90));

  // A small stamp comes back to the nanosecond.
  LaserScan early = flaser_scan();
  early.stamp = 12.345678912345;
  expect_same_scan(scan_from_ros(scan_to_ros(early, "laser")), early, 0.5e-9 + 1e-15);
}

TEST(RosScan, ReadingsBeyondMaxRangeComeBackAtMaxRange) {
  // CARMEN logs hold 81.91 m no-returns with a maximum of 81.9 m: ROS readers discard readings
  // above range_max, and scan_from_ros gives them back as range_max, still no-returns.
  LaserScan s = flaser_scan();
  s.ranges[5] = 81.91f;
  s.ranges[6] = 1000.0f;
  const sensor_msgs::msg::LaserScan m = scan_to_ros(s, "laser");
  EXPECT_EQ(m.ranges()[5], 81.91f);  // published as they are
  const LaserScan back = scan_from_ros(m);
  EXPECT_EQ(back.ranges[5], 81.9f);
  EXPECT_EQ(back.ranges[6], 81.9f);
  EXPECT_TRUE(back.is_no_return(5));
  EXPECT_TRUE(back.is_no_return(6));
  EXPECT_EQ(back.ranges[7], s.ranges[7]);
}

TEST(RosScan, NegativeIncrementScanRoundTripsBitForBit) {
  LaserScan s;
  s.stamp = 42.25;
  s.angle_min = static_cast<float>(kPi / 2);
  s.angle_increment = static_cast<float>(-kPi / 360);
  s.max_range = 30.0f;
  for (int i = 0; i < 361; ++i)
    s.ranges.push_back(i % 7 == 0 ? 30.0f : 1.0f + 0.01f * static_cast<float>(i));
  const sensor_msgs::msg::LaserScan m = scan_to_ros(s, "laser");
  EXPECT_LT(m.angle_increment(), 0.0f);
  EXPECT_LT(m.angle_max(), m.angle_min());
  EXPECT_NEAR(m.angle_max(), -kPi / 2, 1e-5);
  expect_same_scan(scan_from_ros(m), s, 0.0);
}

/// A valid ROS scan with 181 beams over 180 degrees, all readings 2 m, range 0.1..30 m.
sensor_msgs::msg::LaserScan ros_scan() {
  sensor_msgs::msg::LaserScan m;
  m.header().stamp().sec(100);
  m.header().stamp().nanosec(250'000'000);
  m.header().frame_id("laser");
  m.angle_min(static_cast<float>(-kPi / 2));
  m.angle_increment(static_cast<float>(kPi / 180));
  m.angle_max(static_cast<float>(kPi / 2));
  m.range_min(0.1f);
  m.range_max(30.0f);
  m.ranges(std::vector<float>(181, 2.0f));
  return m;
}

TEST(RosScan, UnusableReadingsBecomeNoReturns) {
  sensor_msgs::msg::LaserScan m = ros_scan();
  m.ranges()[1] = kNaN;
  m.ranges()[2] = kInf;
  m.ranges()[3] = -kInf;
  m.ranges()[4] = 0.05f;   // below range_min
  m.ranges()[5] = 30.0f;   // at range_max
  m.ranges()[6] = 45.0f;   // above range_max
  m.ranges()[7] = -1.0f;   // negative
  m.ranges()[8] = 0.1f;    // exactly range_min: a reading
  m.ranges()[9] = 29.99f;  // just below range_max: a reading
  const LaserScan s = scan_from_ros(m);
  EXPECT_EQ(s.stamp, 100.25);
  EXPECT_EQ(s.max_range, 30.0f);
  EXPECT_EQ(s.angle_min, m.angle_min());
  EXPECT_EQ(s.angle_increment, m.angle_increment());
  ASSERT_EQ(s.ranges.size(), 181u);
  for (std::size_t i = 1; i <= 7; ++i) {
    EXPECT_EQ(s.ranges[i], 30.0f) << i;
    EXPECT_TRUE(s.is_no_return(i)) << i;
  }
  EXPECT_EQ(s.ranges[0], 2.0f);
  EXPECT_EQ(s.ranges[8], 0.1f);
  EXPECT_EQ(s.ranges[9], 29.99f);
  EXPECT_FALSE(s.is_no_return(8));
  EXPECT_FALSE(s.is_no_return(9));
}

TEST(RosScan, EachRefusalHasItsKind) {
  auto kind_of = [](const std::function<void(sensor_msgs::msg::LaserScan&)>& spoil) {
    sensor_msgs::msg::LaserScan m = ros_scan();
    spoil(m);
    return refusal([&] { scan_from_ros(m); });
  };
  EXPECT_EQ(kind_of([](auto&) {}), "");
  EXPECT_EQ(kind_of([](auto& m) { m.angle_increment(kNaN); }), "scan_bad_angles");
  EXPECT_EQ(kind_of([](auto& m) { m.angle_increment(0.0f); }), "scan_bad_angles");
  EXPECT_EQ(kind_of([](auto& m) { m.angle_increment(1.5f); }), "scan_bad_angles");
  EXPECT_EQ(kind_of([](auto& m) { m.angle_increment(-1.5f); }), "scan_bad_angles");
  EXPECT_EQ(kind_of([](auto& m) { m.angle_increment(kInf); }), "scan_bad_angles");
  EXPECT_EQ(kind_of([](auto& m) { m.angle_min(kNaN); }), "scan_bad_angles");
  EXPECT_EQ(kind_of([](auto& m) { m.angle_max(kNaN); }), "scan_bad_angles");
  EXPECT_EQ(kind_of([](auto& m) { m.angle_min(-7.0f); }), "scan_bad_angles");
  // The angles say 181 beams.
  EXPECT_EQ(kind_of([](auto& m) { m.ranges().resize(90); }), "scan_ranges_mismatch");
  EXPECT_EQ(kind_of([](auto& m) { m.ranges().resize(179); }), "scan_ranges_mismatch");
  EXPECT_EQ(kind_of([](auto& m) { m.ranges().resize(183); }), "scan_ranges_mismatch");
  // ... one beam more or less is a rounded angle_max.
  EXPECT_EQ(kind_of([](auto& m) { m.ranges().resize(180, 2.0f); }), "");
  EXPECT_EQ(kind_of([](auto& m) { m.ranges().resize(182, 2.0f); }), "");
  // An increment of the wrong sign gives a negative count.
  EXPECT_EQ(kind_of([](auto& m) { m.angle_increment(-m.angle_increment()); }),
            "scan_ranges_mismatch");
  EXPECT_EQ(kind_of([](auto& m) { m.ranges().assign(1'000'000, 2.0f); }), "scan_too_many_beams");
  EXPECT_EQ(kind_of([](auto& m) { m.ranges().assign(kMaxRosScanBeams + 1, 2.0f); }),
            "scan_too_many_beams");
  EXPECT_EQ(kind_of([](auto& m) { m.ranges().assign(1, 2.0f); }), "scan_too_many_beams");
  EXPECT_EQ(kind_of([](auto& m) { m.ranges().clear(); }), "scan_too_many_beams");
  EXPECT_EQ(kind_of([](auto& m) {
              m.range_min(5.0f);
              m.range_max(2.0f);
            }),
            "scan_bad_range_limits");
  EXPECT_EQ(kind_of([](auto& m) { m.range_min(30.0f); }), "scan_bad_range_limits");
  EXPECT_EQ(kind_of([](auto& m) { m.range_min(-0.1f); }), "scan_bad_range_limits");
  EXPECT_EQ(kind_of([](auto& m) { m.range_max(kInf); }), "scan_bad_range_limits");
  EXPECT_EQ(kind_of([](auto& m) { m.range_max(kNaN); }), "scan_bad_range_limits");
  EXPECT_EQ(kind_of([](auto& m) { m.range_min(kNaN); }), "scan_bad_range_limits");
  EXPECT_EQ(kind_of([](auto& m) { m.header().stamp().nanosec(1'000'000'000); }), "bad_stamp");
  EXPECT_EQ(kind_of([](auto& m) { m.header().stamp().nanosec(4'000'000'000u); }), "bad_stamp");
  EXPECT_EQ(kind_of([](auto& m) { m.header().stamp().sec(-2'000'000'000); }), "bad_stamp");
}

TEST(RosScan, RefusalsSayWhatWasWrong) {
  sensor_msgs::msg::LaserScan m = ros_scan();
  m.ranges().resize(90);
  try {
    scan_from_ros(m);
    FAIL() << "not refused";
  } catch (const RosMessageError& e) {
    EXPECT_TRUE(has(e.what(), "90")) << e.what();
    EXPECT_TRUE(has(e.what(), "181")) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------
// Poses, odometry, transforms, pose hints

double angle_error(double a, double b) { return std::abs(normalize_angle(a - b)); }

const std::vector<double> kYaws = {0.0,         0.3,         -0.3,         1.0,  -2.5,
                                   kPi / 2,     -kPi / 2,    3.0,          -3.0, kPi - 1e-9,
                                   -kPi + 1e-9, kPi - 1e-13, -kPi + 1e-13, kPi,  -kPi};

TEST(RosPose, OdometryRoundTripsThroughTheQuaternion) {
  for (double yaw : kYaws) {
    const TimedPose p{1'100'000'000.5, Pose2{12.25, -3.5, yaw}};
    const nav_msgs::msg::Odometry m = odom_to_ros(p, "robot1/odom", "robot1/base_link");
    EXPECT_EQ(m.header().frame_id(), "robot1/odom");
    EXPECT_EQ(m.child_frame_id(), "robot1/base_link");
    EXPECT_EQ(m.header().stamp().sec(), 1'100'000'000);
    EXPECT_EQ(m.header().stamp().nanosec(), 500'000'000u);
    const auto& q = m.pose().pose().orientation();
    EXPECT_EQ(q.x(), 0.0);
    EXPECT_EQ(q.y(), 0.0);
    EXPECT_NEAR(q.x() * q.x() + q.y() * q.y() + q.z() * q.z() + q.w() * q.w(), 1.0, 1e-15);
    EXPECT_NEAR(q.z(), std::sin(yaw / 2), 1e-15);
    EXPECT_NEAR(q.w(), std::cos(yaw / 2), 1e-15);
    EXPECT_EQ(m.pose().pose().position().z(), 0.0);
    const TimedPose back = odom_from_ros(m);
    EXPECT_EQ(back.stamp, p.stamp);
    EXPECT_EQ(back.pose.x, 12.25);
    EXPECT_EQ(back.pose.y, -3.5);
    EXPECT_LT(angle_error(back.pose.theta, yaw), 1e-12) << yaw << " -> " << back.pose.theta;
    EXPECT_LE(std::abs(back.pose.theta), kPi) << yaw;
  }
}

TEST(RosPose, PoseAndTransformRoundTrip) {
  for (double yaw : kYaws) {
    const Pose2 p{-0.75, 4.0, yaw};
    const Pose2 back = pose2_from_ros(pose2_to_ros(p));
    EXPECT_EQ(back.x, p.x);
    EXPECT_EQ(back.y, p.y);
    EXPECT_LT(angle_error(back.theta, yaw), 1e-12) << yaw;

    const geometry_msgs::msg::TransformStamped t =
        transform_to_ros(33.75, "robot1/odom", "robot1/base_link", p);
    EXPECT_EQ(t.header().frame_id(), "robot1/odom");
    EXPECT_EQ(t.child_frame_id(), "robot1/base_link");
    EXPECT_EQ(t.header().stamp().sec(), 33);
    EXPECT_EQ(t.header().stamp().nanosec(), 750'000'000u);
    EXPECT_EQ(t.transform().translation().z(), 0.0);
    const Pose2 tb = pose2_from_ros(t.transform());
    EXPECT_EQ(tb.x, p.x);
    EXPECT_EQ(tb.y, p.y);
    EXPECT_LT(angle_error(tb.theta, yaw), 1e-12) << yaw;
  }
  // A quaternion that is not unit length is normalised first.
  geometry_msgs::msg::Pose scaled = pose2_to_ros(Pose2{0, 0, 2.0});
  scaled.orientation().z(scaled.orientation().z() * 3.0);
  scaled.orientation().w(scaled.orientation().w() * 3.0);
  EXPECT_LT(angle_error(pose2_from_ros(scaled).theta, 2.0), 1e-12);
  // A rotation of pi about z given as (0, 0, 1, 0).
  geometry_msgs::msg::Pose half;
  half.orientation().z(1.0);
  half.orientation().w(0.0);
  EXPECT_LT(angle_error(pose2_from_ros(half).theta, kPi), 1e-12);
}

TEST(RosPose, BadPosesAreRefusedWithTheirKinds) {
  const double nan = std::nan("");
  auto spoiled = [](const std::function<void(geometry_msgs::msg::Pose&)>& spoil) {
    geometry_msgs::msg::Pose p = pose2_to_ros(Pose2{1, 2, 0.5});
    spoil(p);
    return p;
  };
  const std::vector<geometry_msgs::msg::Pose> bad = {
      spoiled([&](auto& p) { p.orientation().z(nan); }),
      spoiled([&](auto& p) { p.orientation().w(std::numeric_limits<double>::infinity()); }),
      spoiled([&](auto& p) {
        p.orientation().z(0.0);
        p.orientation().w(0.0);
      }),
      spoiled([&](auto& p) {
        p.orientation().z(1e-8);
        p.orientation().w(0.0);
      }),
      spoiled([&](auto& p) { p.position().x(nan); }),
      spoiled([&](auto& p) { p.position().y(-std::numeric_limits<double>::infinity()); }),
  };
  for (std::size_t i = 0; i < bad.size(); ++i) {
    EXPECT_EQ(refusal([&] { pose2_from_ros(bad[i]); }), "bad_pose") << i;

    nav_msgs::msg::Odometry odom = odom_to_ros(TimedPose{1.0, Pose2{}}, "odom", "base_link");
    odom.pose().pose(bad[i]);
    EXPECT_EQ(refusal([&] { odom_from_ros(odom); }), "bad_odom") << i;

    geometry_msgs::msg::Transform t;
    t.translation().x(bad[i].position().x());
    t.translation().y(bad[i].position().y());
    t.rotation(bad[i].orientation());
    EXPECT_EQ(refusal([&] { pose2_from_ros(t); }), "bad_transform") << i;

    geometry_msgs::msg::PoseWithCovarianceStamped hint =
        pose_cov_to_ros(TimedPose{1.0, Pose2{}}, "map", 0.5, 0.1);
    hint.pose().pose(bad[i]);
    EXPECT_EQ(refusal([&] { hint_from_ros(hint); }), "bad_initialpose") << i;
  }
  nav_msgs::msg::Odometry late = odom_to_ros(TimedPose{1.0, Pose2{}}, "odom", "base_link");
  late.header().stamp().nanosec(1'000'000'000);
  EXPECT_EQ(refusal([&] { odom_from_ros(late); }), "bad_stamp");
}

TEST(RosPose, HintSigmasComeFromTheCovariance) {
  const geometry_msgs::msg::PoseWithCovarianceStamped m =
      pose_cov_to_ros(TimedPose{20.5, Pose2{3.0, -4.0, -2.0}}, "map", 0.3, 0.1);
  EXPECT_EQ(m.header().frame_id(), "map");
  const auto& cov = m.pose().covariance();
  EXPECT_NEAR(cov[0], 0.09, 1e-15);
  EXPECT_NEAR(cov[7], 0.09, 1e-15);
  EXPECT_NEAR(cov[35], 0.01, 1e-15);
  EXPECT_EQ(cov[1], 0.0);
  EXPECT_EQ(cov[6], 0.0);
  EXPECT_GT(cov[14], 0.0);  // z, roll, pitch fixed but not exactly 0
  RosPoseHint h = hint_from_ros(m);
  EXPECT_EQ(h.frame, "map");
  EXPECT_EQ(h.stamp, 20.5);
  EXPECT_EQ(h.pose.x, 3.0);
  EXPECT_EQ(h.pose.y, -4.0);
  EXPECT_LT(angle_error(h.pose.theta, -2.0), 1e-12);
  EXPECT_NEAR(h.sigma_xy, 0.3, 1e-15);
  EXPECT_NEAR(h.sigma_theta, 0.1, 1e-15);

  // The larger of the x and y variances, whichever it is.
  geometry_msgs::msg::PoseWithCovarianceStamped r = m;
  r.pose().covariance()[0] = 0.04;
  r.pose().covariance()[7] = 0.25;
  r.pose().covariance()[35] = 0.0625;
  h = hint_from_ros(r);
  EXPECT_EQ(h.sigma_xy, 0.5);
  EXPECT_EQ(h.sigma_theta, 0.25);
  r.pose().covariance()[0] = 0.36;
  EXPECT_NEAR(hint_from_ros(r).sigma_xy, 0.6, 1e-15);
  r.pose().covariance()[0] = 0.0;
  r.pose().covariance()[7] = 0.0;
  r.pose().covariance()[35] = 0.0;
  EXPECT_EQ(hint_from_ros(r).sigma_xy, 0.0);

  for (std::size_t i : {0u, 7u, 35u}) {
    for (double bad : {-0.01, std::nan(""), std::numeric_limits<double>::infinity()}) {
      geometry_msgs::msg::PoseWithCovarianceStamped b = m;
      b.pose().covariance()[i] = bad;
      EXPECT_EQ(refusal([&] { hint_from_ros(b); }), "bad_initialpose") << i << " " << bad;
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Occupancy grid

/// A map of 10 cm cells in 8x8 tiles: occupied (-3, 2) in tile (-1, 0), free (0, 0) in tile
/// (0, 0), undecided (9, -1) and occupied (10, -2) in tile (1, -1).
GridMap small_map() {
  GridMapConfig c;
  c.cell_size = 0.1;
  c.tile_edge = 8;
  GridMap map(c);
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(map.add_hit({-3, 2}));
  EXPECT_TRUE(map.add_err({0, 0}));
  EXPECT_TRUE(map.add_hit({9, -1}));
  EXPECT_TRUE(map.add_err({9, -1}));
  EXPECT_TRUE(map.add_hit({10, -2}));
  EXPECT_TRUE(map.add_hit({10, -2}));
  EXPECT_TRUE(map.add_err({10, -2}));  // p = 2/3 >= 0.65: occupied
  EXPECT_TRUE(map.add_err({-8, -8}));  // the lower-left cell of tile (-1, -1)
  map.commit_update();
  return map;
}

/// The cell at (x, y) of row-major `data` of `width` from the lower-left cell `min`.
std::int8_t at(const std::vector<std::int8_t>& data, std::int32_t width, CellIndex min,
               std::int32_t x, std::int32_t y) {
  return data.at(static_cast<std::size_t>((y - min.y) * width + (x - min.x)));
}

TEST(RosGrid, WindowIsTheBoundingBoxOfTheTiles) {
  const GridMap map = small_map();
  ASSERT_EQ(map.tile_count(), 4u);  // (-1, -1), (-1, 0), (0, 0), (1, -1)
  const RosGridWindow w = map_window(map);
  EXPECT_EQ(w.min, (CellIndex{-8, -8}));
  EXPECT_EQ(w.width, 24);
  EXPECT_EQ(w.height, 16);
  EXPECT_EQ(tiles_window(map, {TileKey{0, 0}}), (RosGridWindow{{0, 0}, 8, 8}));
  EXPECT_EQ(tiles_window(map, {TileKey{1, -1}}), (RosGridWindow{{8, -8}, 8, 8}));
  EXPECT_EQ(tiles_window(map, {TileKey{1, -1}, TileKey{-1, 0}}), w);
  EXPECT_EQ(tiles_window(map, {TileKey{0, 0}, TileKey{2, 3}}), (RosGridWindow{{0, 0}, 24, 32}));
  EXPECT_EQ(tiles_window(map, {}).width, 0);
  EXPECT_EQ(tiles_window(map, {}).height, 0);
  const GridMap empty(GridMapConfig{0.1, 8});
  EXPECT_EQ(map_window(empty).width, 0);
  EXPECT_EQ(map_window(empty).height, 0);
}

TEST(RosGrid, WindowContains) {
  const RosGridWindow w{{-8, -8}, 24, 16};
  EXPECT_TRUE(w.contains(w));
  EXPECT_TRUE(w.contains(RosGridWindow{{8, -8}, 8, 8}));
  EXPECT_TRUE(w.contains(RosGridWindow{{-8, 0}, 8, 8}));
  EXPECT_TRUE(w.contains(RosGridWindow{{0, 0}, 0, 0}));
  EXPECT_FALSE(w.contains(RosGridWindow{{16, -8}, 8, 8}));  // sticks out right
  EXPECT_FALSE(w.contains(RosGridWindow{{-8, 0}, 8, 9}));   // sticks out at the top
  EXPECT_FALSE(w.contains(RosGridWindow{{-9, -8}, 8, 8}));  // sticks out left
  EXPECT_FALSE(w.contains(RosGridWindow{{-8, -9}, 8, 8}));  // sticks out at the bottom
  EXPECT_FALSE((RosGridWindow{{8, -8}, 8, 8}).contains(w));
  EXPECT_FALSE((RosGridWindow{{-8, -8}, 24, 15}).contains(w));
}

TEST(RosGrid, GridHoldsEveryCellsRosValueRowMajorFromTheLowerLeft) {
  const GridMap map = small_map();
  const RosGridWindow w = map_window(map);
  const OccupancyThresholds th;
  const nav_msgs::msg::OccupancyGrid g = grid_to_ros(map, w, th, 1234.5, "map");
  EXPECT_EQ(g.header().frame_id(), "map");
  EXPECT_EQ(g.header().stamp().sec(), 1234);
  EXPECT_EQ(g.header().stamp().nanosec(), 500'000'000u);
  EXPECT_EQ(g.info().resolution(), 0.1f);
  EXPECT_EQ(g.info().width(), 24u);
  EXPECT_EQ(g.info().height(), 16u);
  EXPECT_NEAR(g.info().origin().position().x(), -0.8, 1e-12);
  EXPECT_NEAR(g.info().origin().position().y(), -0.8, 1e-12);
  EXPECT_EQ(g.info().origin().position().z(), 0.0);
  EXPECT_EQ(g.info().origin().orientation().w(), 1.0);
  EXPECT_EQ(g.info().origin().orientation().z(), 0.0);
  ASSERT_EQ(g.data().size(), 24u * 16u);

  EXPECT_EQ(at(g.data(), 24, w.min, -3, 2), 100);
  EXPECT_EQ(at(g.data(), 24, w.min, 0, 0), 0);
  EXPECT_EQ(at(g.data(), 24, w.min, 9, -1), -1);  // p = 0.5
  EXPECT_EQ(at(g.data(), 24, w.min, 10, -2), 100);
  EXPECT_EQ(at(g.data(), 24, w.min, -8, -8), 0);
  EXPECT_EQ(g.data()[0], 0);  // row 0, column 0 is the lower-left cell (-8, -8)
  // Every cell, tiles that do not exist included (tile (0, -1), (1, 0): unknown).
  int occupied = 0, free_cells = 0;
  for (std::int32_t y = w.min.y; y < w.min.y + w.height; ++y) {
    for (std::int32_t x = w.min.x; x < w.min.x + w.width; ++x) {
      const CellIndex c{x, y};
      EXPECT_EQ(at(g.data(), 24, w.min, x, y), ros_cell_value(map.hit(c), map.err(c), th))
          << x << "," << y;
    }
  }
  for (std::int8_t v : g.data()) {
    occupied += v == 100;
    free_cells += v == 0;
  }
  EXPECT_EQ(occupied, 2);
  EXPECT_EQ(free_cells, 2);

  // Other thresholds give other values: p = 0.5 is occupied at 0.4.
  OccupancyThresholds low;
  low.occupied = 0.4;
  low.min_hits = 1;
  low.free = 0.1;
  EXPECT_EQ(at(grid_to_ros(map, w, low, 0.0, "map").data(), 24, w.min, 9, -1), 100);

  // A window of one tile only holds that tile.
  const RosGridWindow one = tiles_window(map, {TileKey{-1, 0}});
  const nav_msgs::msg::OccupancyGrid g1 = grid_to_ros(map, one, th, 0.0, "map");
  EXPECT_NEAR(g1.info().origin().position().x(), -0.8, 1e-12);
  EXPECT_NEAR(g1.info().origin().position().y(), 0.0, 1e-12);
  ASSERT_EQ(g1.data().size(), 64u);
  EXPECT_EQ(at(g1.data(), 8, one.min, -3, 2), 100);
  EXPECT_EQ(std::count(g1.data().begin(), g1.data().end(), std::int8_t{-1}), 63);

  // An empty map: an empty grid.
  const GridMap empty(GridMapConfig{0.1, 8});
  EXPECT_TRUE(grid_to_ros(empty, map_window(empty), th, 0.0, "map").data().empty());
}

TEST(RosGrid, UpdateIsARectangleInTheWindowsCoordinates) {
  const GridMap map = small_map();
  const RosGridWindow w = map_window(map);
  const OccupancyThresholds th;
  const nav_msgs::msg::OccupancyGrid g = grid_to_ros(map, w, th, 0.0, "map");
  const RosGridWindow rect = tiles_window(map, {TileKey{1, -1}});
  ASSERT_TRUE(w.contains(rect));
  const map_msgs::msg::OccupancyGridUpdate u = update_to_ros(map, w, rect, th, 7.5, "map");
  EXPECT_EQ(u.header().frame_id(), "map");
  EXPECT_EQ(u.header().stamp().sec(), 7);
  EXPECT_EQ(u.x(), 16);  // cell 8 of the window starting at -8
  EXPECT_EQ(u.y(), 0);
  EXPECT_EQ(u.width(), 8u);
  EXPECT_EQ(u.height(), 8u);
  ASSERT_EQ(u.data().size(), 64u);
  EXPECT_EQ(at(u.data(), 8, rect.min, 10, -2), 100);
  EXPECT_EQ(at(u.data(), 8, rect.min, 9, -1), -1);
  // The update's cells are the grid's cells at (x + col, y + row).
  for (std::uint32_t row = 0; row < u.height(); ++row) {
    for (std::uint32_t col = 0; col < u.width(); ++col) {
      EXPECT_EQ(u.data()[row * u.width() + col],
                g.data().at((static_cast<std::uint32_t>(u.y()) + row) * g.info().width() +
                            static_cast<std::uint32_t>(u.x()) + col))
          << row << "," << col;
    }
  }
  // A rectangle that is not a whole tile, across tiles, at the window's top.
  const RosGridWindow odd{{-4, 1}, 6, 7};
  const map_msgs::msg::OccupancyGridUpdate v = update_to_ros(map, w, odd, th, 0.0, "map");
  EXPECT_EQ(v.x(), 4);
  EXPECT_EQ(v.y(), 9);
  ASSERT_EQ(v.data().size(), 42u);
  EXPECT_EQ(at(v.data(), 6, odd.min, -3, 2), 100);
  EXPECT_EQ(at(v.data(), 6, odd.min, 0, 1), -1);
  EXPECT_EQ(std::count(v.data().begin(), v.data().end(), std::int8_t{-1}), 41);
}

}  // namespace
}  // namespace esfleet::dds
