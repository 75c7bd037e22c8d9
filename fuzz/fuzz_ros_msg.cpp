// libFuzzer target: a ROS 2 message as a peer puts it on the wire (CDR with its encapsulation
// header), deserialized by the generated type support as Fast DDS does on reception, then
// checked and converted by dds/ros_msg (what RosScanSource and InitialPoseInput do with it).
// Input: byte 0 picks the type (LaserScan, Odometry, PoseWithCovarianceStamped, TFMessage), the
// rest is the serialized payload. Invariants:
//  - a conversion either throws RosMessageError (with a kind) or gives finite values;
//  - an accepted scan has 2..kMaxRosScanBeams readings, each finite and in [0, max_range],
//    a finite non-zero increment, and angles within 2 pi;
//  - an accepted pose has a heading in [-pi, pi]; a hint has finite, non-negative sigmas.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <numbers>

#include <esfleet/msg/ros2PubSubTypes.h>
#include <fastdds/rtps/common/SerializedPayload.h>

#include "esfleet/dds/ros_msg.hpp"
#include "fuzz_check.hpp"

using esfleet::fuzz::check;
namespace dds = esfleet::dds;

namespace {

/// Deserializes `data` as Msg the way Fast DDS does for a received sample; false if refused.
template <class PubSub, class Msg>
bool deserialize(const std::uint8_t* data, std::size_t size, Msg& out) {
  eprosima::fastrtps::rtps::SerializedPayload_t payload(static_cast<std::uint32_t>(size));
  if (size > 0) std::memcpy(payload.data, data, size);
  payload.length = static_cast<std::uint32_t>(size);
  PubSub type;
  try {
    return type.deserialize(&payload, &out);
  } catch (...) {
    return false;  // fastcdr's NotEnoughMemoryException and friends: Fast DDS drops the sample
  }
}

bool heading_ok(double theta) {
  return std::isfinite(theta) && std::abs(theta) <= std::numbers::pi + 1e-12;
}

void fuzz_scan(const std::uint8_t* data, std::size_t size) {
  sensor_msgs::msg::LaserScan m;
  if (!deserialize<sensor_msgs::msg::LaserScanPubSubType>(data, size, m)) return;
  try {
    const esfleet::LaserScan s = dds::scan_from_ros(m);
    check(s.ranges.size() >= 2 && s.ranges.size() <= dds::kMaxRosScanBeams, "beam count");
    check(std::isfinite(s.angle_increment) && s.angle_increment != 0.0f, "increment");
    check(std::isfinite(s.angle_min) && std::abs(s.angle_min) <= 2 * std::numbers::pi, "angle");
    check(std::isfinite(s.max_range) && s.max_range > 0.0f, "max_range");
    check(std::isfinite(s.stamp) && s.stamp >= 0.0, "stamp");
    for (const float r : s.ranges) {
      check(std::isfinite(r) && r >= 0.0f && r <= s.max_range, "reading in [0, max_range]");
    }
  } catch (const dds::RosMessageError& e) {
    check(!e.kind().empty(), "a refusal has a kind");
  }
}

void fuzz_odom(const std::uint8_t* data, std::size_t size) {
  nav_msgs::msg::Odometry m;
  if (!deserialize<nav_msgs::msg::OdometryPubSubType>(data, size, m)) return;
  try {
    const esfleet::TimedPose p = dds::odom_from_ros(m);
    check(std::isfinite(p.pose.x) && std::isfinite(p.pose.y) && heading_ok(p.pose.theta),
          "odometry pose finite");
  } catch (const dds::RosMessageError& e) {
    check(!e.kind().empty(), "a refusal has a kind");
  }
}

void fuzz_hint(const std::uint8_t* data, std::size_t size) {
  geometry_msgs::msg::PoseWithCovarianceStamped m;
  if (!deserialize<geometry_msgs::msg::PoseWithCovarianceStampedPubSubType>(data, size, m)) {
    return;
  }
  try {
    const dds::RosPoseHint h = dds::hint_from_ros(m);
    check(std::isfinite(h.pose.x) && std::isfinite(h.pose.y) && heading_ok(h.pose.theta),
          "hint pose finite");
    check(std::isfinite(h.sigma_xy) && h.sigma_xy >= 0.0 && std::isfinite(h.sigma_theta) &&
              h.sigma_theta >= 0.0,
          "hint sigmas finite and >= 0");
  } catch (const dds::RosMessageError& e) {
    check(!e.kind().empty(), "a refusal has a kind");
  }
}

void fuzz_tf(const std::uint8_t* data, std::size_t size) {
  tf2_msgs::msg::TFMessage m;
  if (!deserialize<tf2_msgs::msg::TFMessagePubSubType>(data, size, m)) return;
  for (const auto& t : m.transforms()) {
    try {
      const esfleet::Pose2 p = dds::pose2_from_ros(t.transform());
      check(std::isfinite(p.x) && std::isfinite(p.y) && heading_ok(p.theta), "transform finite");
      (void)dds::seconds_of(t.header().stamp());
    } catch (const dds::RosMessageError& e) {
      check(!e.kind().empty(), "a refusal has a kind");
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  switch (data[0] % 4) {
    case 0:
      fuzz_scan(data + 1, size - 1);
      break;
    case 1:
      fuzz_odom(data + 1, size - 1);
      break;
    case 2:
      fuzz_hint(data + 1, size - 1);
      break;
    default:
      fuzz_tf(data + 1, size - 1);
      break;
  }
  return 0;
}
