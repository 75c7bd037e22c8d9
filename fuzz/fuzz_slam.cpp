// libFuzzer target: the SLAM fed what the wire lets through. A few ROS 2 LaserScan and Odometry
// messages (built field by field from the input, then checked and converted by dds/ros_msg as
// RosScanSource does) go through Slam::process, and a follower's contributed scan (checked by
// dds::contribution_from_msg) through Slam::contribute; at the end, maybe Slam::finish. The
// converters let through any finite odometry, any scan geometry they accept and any reading
// below the declared maximum: this target asks what the SLAM makes of them.
//
// Input: one byte of switches (odometry on, the paper's configuration, a contribution,
// finish), the number of scans (1..4), then per scan its beam count (2..720), angles, range
// limits, readings (in centimetres, as raw floats, or one value for all) and an odometry pose.
// Invariants, besides no crash and no sanitizer report:
//  - every pose the SLAM returns, and every trajectory pose, is finite;
//  - a scan's map update writes only within the map-writing range (MapUpdateConfig::
//    write_range) of its pose: no tile created by one step lies farther away;
//  - libFuzzer's -timeout and -rss_limit_mb (fuzz/run.sh) bound what one input may cost.

#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <set>
#include <vector>

#include "esfleet/core/slam.hpp"
#include "esfleet/dds/from_msg.hpp"
#include "esfleet/dds/ros_msg.hpp"
#include "fuzz_check.hpp"

using esfleet::fuzz::check;
namespace dds = esfleet::dds;

namespace {

constexpr std::uint16_t kMaxBeams = 720;  // a 0.5 deg laser over 360 deg: keeps one input fast

bool finite(const esfleet::Pose2& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta);
}

/// The scan's readings as the fuzzer chose them: centimetres (what a real laser gives), raw
/// floats (NaN, inf, subnormals, huge values), or one value for every beam.
std::vector<float> readings(FuzzedDataProvider& in, std::size_t n) {
  std::vector<float> r(n);
  switch (in.ConsumeIntegralInRange<int>(0, 2)) {
    case 0:
      for (float& v : r) v = static_cast<float>(in.ConsumeIntegral<std::uint16_t>()) * 0.01f;
      break;
    case 1:
      for (float& v : r) v = in.ConsumeFloatingPoint<float>();
      break;
    default:
      std::fill(r.begin(), r.end(), in.ConsumeFloatingPoint<float>());
      break;
  }
  return r;
}

/// A LaserScan message as a driver (or a hostile peer) may publish it.
sensor_msgs::msg::LaserScan scan_message(FuzzedDataProvider& in, double stamp) {
  sensor_msgs::msg::LaserScan m;
  const auto n = in.ConsumeIntegralInRange<std::uint16_t>(2, kMaxBeams);
  const float angle_min = in.ConsumeFloatingPointInRange<float>(-7.0f, 7.0f);
  const float increment = in.ConsumeFloatingPointInRange<float>(-1.1f, 1.1f);
  m.header().stamp().sec(static_cast<std::int32_t>(stamp));
  m.angle_min(angle_min);
  m.angle_increment(increment);
  m.angle_max(angle_min + static_cast<float>(n - 1) * increment);
  m.range_min(in.ConsumeFloatingPointInRange<float>(0.0f, 5.0f));
  m.range_max(in.ConsumeBool() ? in.ConsumeFloatingPointInRange<float>(0.0f, 2000.0f)
                               : in.ConsumeFloatingPoint<float>());
  m.ranges(readings(in, n));
  return m;
}

/// An odometry message: any position (the converter checks only that it is finite) and yaw.
nav_msgs::msg::Odometry odom_message(FuzzedDataProvider& in) {
  nav_msgs::msg::Odometry m;
  auto& p = m.pose().pose();
  const bool wild = in.ConsumeBool();
  p.position().x(wild ? in.ConsumeFloatingPoint<double>()
                      : in.ConsumeFloatingPointInRange<double>(-50.0, 50.0));
  p.position().y(wild ? in.ConsumeFloatingPoint<double>()
                      : in.ConsumeFloatingPointInRange<double>(-50.0, 50.0));
  const double yaw = in.ConsumeFloatingPointInRange<double>(-4.0, 4.0);
  p.orientation().z(std::sin(yaw / 2.0));
  p.orientation().w(std::cos(yaw / 2.0));
  return m;
}

/// A follower's contributed scan message.
esfleet::msg::ContributedScan contribution_message(FuzzedDataProvider& in) {
  esfleet::msg::ContributedScan m;
  m.robot_id("f1");
  m.map_id("m");
  m.seq(1);
  m.x(in.ConsumeFloatingPoint<double>());
  m.y(in.ConsumeFloatingPoint<double>());
  m.theta(in.ConsumeFloatingPoint<double>());
  m.agreement(in.ConsumeProbability<float>());
  m.known(in.ConsumeProbability<float>());
  m.angle_min(in.ConsumeFloatingPointInRange<float>(-7.0f, 7.0f));
  m.angle_increment(in.ConsumeFloatingPointInRange<float>(-1.0f, 1.0f));
  m.max_range(in.ConsumeFloatingPointInRange<float>(0.0f, 1000.0f));
  std::vector<std::uint16_t> mm(in.ConsumeIntegralInRange<std::uint16_t>(1, kMaxBeams));
  for (auto& v : mm) v = in.ConsumeIntegral<std::uint16_t>();
  m.ranges_mm(mm);
  return m;
}

/// Checks that the tiles `before` lacked lie within the write range of `pose`.
void check_new_tiles(const esfleet::GridMap& map, const std::set<esfleet::TileKey>& before,
                     const esfleet::Pose2& pose, double write_range) {
  const double tile = map.cell_size() * map.tile_edge();
  for (const esfleet::TileKey k : map.tile_keys()) {
    if (before.count(k) != 0) continue;
    const double nx = std::clamp(pose.x, k.tx * tile, (k.tx + 1) * tile);
    const double ny = std::clamp(pose.y, k.ty * tile, (k.ty + 1) * tile);
    check(std::hypot(nx - pose.x, ny - pose.y) <= write_range + map.cell_size(),
          "a scan's new tiles lie within the write range of its pose");
  }
}

std::set<esfleet::TileKey> keys_of(const esfleet::GridMap& map) {
  const auto keys = map.tile_keys();
  return {keys.begin(), keys.end()};
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  const auto switches = in.ConsumeIntegral<std::uint8_t>();
  esfleet::SlamConfig config =
      (switches & 2) != 0 ? esfleet::SlamConfig::paper() : esfleet::SlamConfig{};
  config.tracking.use_odometry = (switches & 1) != 0;
  config.loop.speculate = false;  // one thread: an input's outcome does not depend on timing
  esfleet::Slam slam(config);

  const int scans = in.ConsumeIntegralInRange<int>(1, 4);
  for (int i = 0; i < scans; ++i) {
    esfleet::LaserScan scan;
    try {
      scan = dds::scan_from_ros(scan_message(in, i));
    } catch (const dds::RosMessageError& e) {
      check(!e.kind().empty(), "a refusal has a kind");
      continue;
    }
    try {
      scan.odometry = dds::odom_from_ros(odom_message(in)).pose;
    } catch (const dds::RosMessageError& e) {
      check(!e.kind().empty(), "a refusal has a kind");
    }
    const auto before = keys_of(slam.map());
    const std::size_t closures = slam.loop_closures();
    const esfleet::SlamStep step = slam.process(scan);
    check(finite(step.pose), "the scan's pose is finite");
    // A loop closure re-writes key scans at their new poses, which may lie anywhere.
    if (slam.loop_closures() == closures) {
      check_new_tiles(slam.map(), before, step.pose, config.update.write_range);
    }
  }

  if ((switches & 4) != 0) {
    try {
      const auto received = dds::contribution_from_msg(contribution_message(in));
      const auto result = slam.contribute(received.contribution);
      check(finite(result.refined), "a contribution's refined pose is finite");
    } catch (const std::invalid_argument&) {
      // refused by the converter, as the leader refuses it
    }
  }
  if ((switches & 8) != 0) slam.finish();
  for (const auto& p : slam.trajectory()) check(finite(p.pose), "trajectory poses are finite");
  return 0;
}
