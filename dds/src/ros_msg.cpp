#include "esfleet/dds/ros_msg.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

namespace esfleet::dds {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::uint32_t checked_nanosec(std::uint32_t ns) {
  if (ns >= 1'000'000'000u) {
    throw RosMessageError("bad_stamp", "stamp nanosec " + std::to_string(ns) + " is >= 1e9");
  }
  return ns;
}

std_msgs::msg::Header header(double stamp, const std::string& frame) {
  std_msgs::msg::Header h;
  h.stamp(ros_time(stamp));
  h.frame_id(frame);
  return h;
}

/// Yaw of a quaternion; throws `kind` if it is not finite or (almost) zero.
double yaw_of(const geometry_msgs::msg::Quaternion& q, const char* kind) {
  const double n = std::sqrt(q.x() * q.x() + q.y() * q.y() + q.z() * q.z() + q.w() * q.w());
  if (!std::isfinite(n) || n < 1e-6) {
    throw RosMessageError(kind, "orientation quaternion (" + num(q.x()) + ", " + num(q.y()) + ", " +
                                    num(q.z()) + ", " + num(q.w()) + ") is not a rotation");
  }
  const double x = q.x() / n, y = q.y() / n, z = q.z() / n, w = q.w() / n;
  return std::atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z));
}

geometry_msgs::msg::Quaternion quaternion_of(double yaw) {
  geometry_msgs::msg::Quaternion q;
  q.x(0.0);
  q.y(0.0);
  q.z(std::sin(yaw / 2.0));
  q.w(std::cos(yaw / 2.0));
  return q;
}

Pose2 planar(double x, double y, const geometry_msgs::msg::Quaternion& q, const char* kind) {
  if (!std::isfinite(x) || !std::isfinite(y)) {
    throw RosMessageError(kind, "position (" + num(x) + ", " + num(y) + ") is not finite");
  }
  return Pose2{x, y, yaw_of(q, kind)};
}

void check_scan_angles(const sensor_msgs::msg::LaserScan& m) {
  const double a0 = m.angle_min(), a1 = m.angle_max(), inc = m.angle_increment();
  if (!std::isfinite(a0) || !std::isfinite(a1) || !std::isfinite(inc) || std::abs(a0) > kTwoPi ||
      std::abs(a1) > kTwoPi || inc == 0.0 || std::abs(inc) > 1.0) {
    throw RosMessageError("scan_bad_angles", "angle_min " + num(a0) + ", angle_max " + num(a1) +
                                                 ", angle_increment " + num(inc) +
                                                 " do not describe a scan");
  }
  const std::size_t n = m.ranges().size();
  if (n < 2 || n > kMaxRosScanBeams) {
    throw RosMessageError("scan_too_many_beams", "ranges holds " + std::to_string(n) +
                                                     " readings, need 2.." +
                                                     std::to_string(kMaxRosScanBeams));
  }
  const double expected = (a1 - a0) / inc + 1.0;
  if (!(std::abs(expected - static_cast<double>(n)) <= 1.5)) {
    throw RosMessageError(
        "scan_ranges_mismatch",
        "the angles give " + num(expected) + " beams but ranges holds " + std::to_string(n));
  }
  const double lo = m.range_min(), hi = m.range_max();
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo < 0.0 || !(lo < hi)) {
    throw RosMessageError("scan_bad_range_limits",
                          "range_min " + num(lo) + ", range_max " + num(hi) +
                              " need 0 <= range_min < range_max, both finite");
  }
}

/// Copies the cells of `rect` row by row into `out` (row-major, rect.width per row).
void copy_cells(const GridMap& map, const RosGridWindow& rect, const OccupancyThresholds& th,
                std::vector<std::int8_t>& out) {
  out.assign(static_cast<std::size_t>(rect.width) * static_cast<std::size_t>(rect.height), -1);
  const std::int32_t edge = map.tile_edge();
  for (const TileKey& key : map.tile_keys()) {
    const std::int32_t x0 = key.tx * edge, y0 = key.ty * edge;
    const std::int32_t lx0 = std::max(0, rect.min.x - x0);
    const std::int32_t lx1 = std::min(edge, rect.min.x + rect.width - x0);
    const std::int32_t ly0 = std::max(0, rect.min.y - y0);
    const std::int32_t ly1 = std::min(edge, rect.min.y + rect.height - y0);
    if (lx0 >= lx1 || ly0 >= ly1) continue;
    const Tile* tile = map.find_tile(key);
    for (std::int32_t ly = ly0; ly < ly1; ++ly) {
      const auto row = static_cast<std::size_t>(y0 + ly - rect.min.y);
      for (std::int32_t lx = lx0; lx < lx1; ++lx) {
        const auto i = static_cast<std::size_t>(ly * edge + lx);
        const auto col = static_cast<std::size_t>(x0 + lx - rect.min.x);
        out[row * static_cast<std::size_t>(rect.width) + col] =
            ros_cell_value(tile->hit[i], tile->err[i], th);
      }
    }
  }
}

}  // namespace

builtin_interfaces::msg::Time ros_time(double seconds) {
  builtin_interfaces::msg::Time t;
  if (!std::isfinite(seconds) || seconds < 0.0 ||
      seconds >= static_cast<double>(std::numeric_limits<std::int32_t>::max())) {
    return t;
  }
  double whole = std::floor(seconds);
  auto ns = static_cast<std::int64_t>(std::llround((seconds - whole) * 1e9));
  if (ns >= 1'000'000'000) {
    whole += 1.0;
    ns -= 1'000'000'000;
  }
  t.sec(static_cast<std::int32_t>(whole));
  t.nanosec(static_cast<std::uint32_t>(ns));
  return t;
}

double seconds_of(const builtin_interfaces::msg::Time& t) {
  if (t.sec() < 0) {
    throw RosMessageError("bad_stamp", "stamp sec " + std::to_string(t.sec()) + " is negative");
  }
  return static_cast<double>(t.sec()) + static_cast<double>(checked_nanosec(t.nanosec())) * 1e-9;
}

LaserScan scan_from_ros(const sensor_msgs::msg::LaserScan& m) {
  check_scan_angles(m);
  LaserScan scan;
  scan.stamp = seconds_of(m.header().stamp());
  scan.angle_min = m.angle_min();
  scan.angle_increment = m.angle_increment();
  scan.max_range = m.range_max();
  scan.ranges = m.ranges();
  for (float& r : scan.ranges) {
    if (!std::isfinite(r) || r < m.range_min() || r >= m.range_max()) r = m.range_max();
  }
  return scan;
}

sensor_msgs::msg::LaserScan scan_to_ros(const LaserScan& scan, const std::string& frame) {
  sensor_msgs::msg::LaserScan m;
  m.header(header(scan.stamp, frame));
  m.angle_min(scan.angle_min);
  const std::size_t n = scan.ranges.size();
  m.angle_max(n == 0 ? scan.angle_min : scan.angle(n - 1));
  m.angle_increment(scan.angle_increment);
  m.time_increment(0.0f);
  m.scan_time(0.0f);
  m.range_min(0.0f);
  m.range_max(scan.max_range);
  m.ranges(scan.ranges);
  return m;
}

Pose2 pose2_from_ros(const geometry_msgs::msg::Pose& p) {
  return planar(p.position().x(), p.position().y(), p.orientation(), "bad_pose");
}

Pose2 pose2_from_ros(const geometry_msgs::msg::Transform& t) {
  return planar(t.translation().x(), t.translation().y(), t.rotation(), "bad_transform");
}

geometry_msgs::msg::Pose pose2_to_ros(const Pose2& p) {
  geometry_msgs::msg::Pose out;
  out.position().x(p.x);
  out.position().y(p.y);
  out.position().z(0.0);
  out.orientation(quaternion_of(p.theta));
  return out;
}

TimedPose odom_from_ros(const nav_msgs::msg::Odometry& m) {
  const geometry_msgs::msg::Pose& p = m.pose().pose();
  return TimedPose{seconds_of(m.header().stamp()),
                   planar(p.position().x(), p.position().y(), p.orientation(), "bad_odom")};
}

nav_msgs::msg::Odometry odom_to_ros(const TimedPose& pose, const std::string& odom_frame,
                                    const std::string& base_frame) {
  nav_msgs::msg::Odometry m;
  m.header(header(pose.stamp, odom_frame));
  m.child_frame_id(base_frame);
  m.pose().pose(pose2_to_ros(pose.pose));
  return m;
}

geometry_msgs::msg::TransformStamped transform_to_ros(double stamp, const std::string& parent,
                                                      const std::string& child,
                                                      const Pose2& child_in_parent) {
  geometry_msgs::msg::TransformStamped t;
  t.header(header(stamp, parent));
  t.child_frame_id(child);
  t.transform().translation().x(child_in_parent.x);
  t.transform().translation().y(child_in_parent.y);
  t.transform().translation().z(0.0);
  t.transform().rotation(quaternion_of(child_in_parent.theta));
  return t;
}

geometry_msgs::msg::PoseWithCovarianceStamped pose_cov_to_ros(const TimedPose& pose,
                                                              const std::string& frame,
                                                              double sigma_xy, double sigma_theta) {
  geometry_msgs::msg::PoseWithCovarianceStamped m;
  m.header(header(pose.stamp, frame));
  m.pose().pose(pose2_to_ros(pose.pose));
  std::array<double, 36> cov{};
  constexpr double kFixed = 1e-9;  // z, roll, pitch: fixed in 2D
  cov[0] = cov[7] = sigma_xy * sigma_xy;
  cov[14] = cov[21] = cov[28] = kFixed;
  cov[35] = sigma_theta * sigma_theta;
  m.pose().covariance(cov);
  return m;
}

RosPoseHint hint_from_ros(const geometry_msgs::msg::PoseWithCovarianceStamped& m) {
  RosPoseHint h;
  h.frame = m.header().frame_id();
  h.stamp = seconds_of(m.header().stamp());
  const geometry_msgs::msg::Pose& p = m.pose().pose();
  h.pose = planar(p.position().x(), p.position().y(), p.orientation(), "bad_initialpose");
  const auto& cov = m.pose().covariance();
  for (const std::size_t i : {0u, 7u, 35u}) {
    if (!std::isfinite(cov[i]) || cov[i] < 0.0) {
      throw RosMessageError("bad_initialpose", "covariance[" + std::to_string(i) +
                                                   "] = " + num(cov[i]) + " is not a variance");
    }
  }
  h.sigma_xy = std::sqrt(std::max(cov[0], cov[7]));
  h.sigma_theta = std::sqrt(cov[35]);
  return h;
}

bool RosGridWindow::contains(const RosGridWindow& o) const {
  return o.min.x >= min.x && o.min.y >= min.y &&
         std::int64_t{o.min.x} + o.width <= std::int64_t{min.x} + width &&
         std::int64_t{o.min.y} + o.height <= std::int64_t{min.y} + height;
}

RosGridWindow tiles_window(const GridMap& map, const std::vector<TileKey>& keys) {
  RosGridWindow w;
  if (keys.empty()) return w;
  std::int32_t tx0 = keys.front().tx, tx1 = tx0, ty0 = keys.front().ty, ty1 = ty0;
  for (const TileKey& k : keys) {
    tx0 = std::min(tx0, k.tx);
    tx1 = std::max(tx1, k.tx);
    ty0 = std::min(ty0, k.ty);
    ty1 = std::max(ty1, k.ty);
  }
  const std::int32_t edge = map.tile_edge();
  w.min = CellIndex{tx0 * edge, ty0 * edge};
  w.width = (tx1 - tx0 + 1) * edge;
  w.height = (ty1 - ty0 + 1) * edge;
  return w;
}

RosGridWindow map_window(const GridMap& map) { return tiles_window(map, map.tile_keys()); }

nav_msgs::msg::OccupancyGrid grid_to_ros(const GridMap& map, const RosGridWindow& window,
                                         const OccupancyThresholds& th, double stamp,
                                         const std::string& frame) {
  nav_msgs::msg::OccupancyGrid m;
  m.header(header(stamp, frame));
  m.info().map_load_time(ros_time(stamp));
  m.info().resolution(static_cast<float>(map.cell_size()));
  m.info().width(static_cast<std::uint32_t>(window.width));
  m.info().height(static_cast<std::uint32_t>(window.height));
  m.info().origin(
      pose2_to_ros(Pose2{window.min.x * map.cell_size(), window.min.y * map.cell_size(), 0.0}));
  copy_cells(map, window, th, m.data());
  return m;
}

map_msgs::msg::OccupancyGridUpdate update_to_ros(const GridMap& map, const RosGridWindow& window,
                                                 const RosGridWindow& rect,
                                                 const OccupancyThresholds& th, double stamp,
                                                 const std::string& frame) {
  map_msgs::msg::OccupancyGridUpdate m;
  m.header(header(stamp, frame));
  m.x(rect.min.x - window.min.x);
  m.y(rect.min.y - window.min.y);
  m.width(static_cast<std::uint32_t>(rect.width));
  m.height(static_cast<std::uint32_t>(rect.height));
  copy_cells(map, rect, th, m.data());
  return m;
}

}  // namespace esfleet::dds
