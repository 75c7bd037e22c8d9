#pragma once
// ROS 2 messages (idl/ros2.idl) to and from esfleet's values: laser scans, odometry, poses,
// transforms and the occupancy grid with its updates. No Fast DDS entities here (only the
// generated message classes). Incoming messages are checked field by field: a message that
// cannot be used is refused with a RosMessageError whose kind() names the check (the programs
// count refusals per kind in stats.json) and whose what() says what was wrong.

#include <cstdint>
#include <stdexcept>
#include <string>

#include <esfleet/msg/ros2.h>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/ros_map_format.hpp"

namespace esfleet::dds {

/// A ROS message refused by a conversion.
class RosMessageError : public std::invalid_argument {
 public:
  /// `kind`: a short stable key ("scan_ranges_mismatch", "scan_bad_angles", ...).
  RosMessageError(std::string kind, const std::string& what)
      : std::invalid_argument(what), kind_(std::move(kind)) {}
  const std::string& kind() const { return kind_; }

 private:
  std::string kind_;
};

/// Most beams a LaserScan may have (as the CARMEN reader: no 2D laser has more).
inline constexpr std::size_t kMaxRosScanBeams = 10000;

/// ROS time of `seconds` (>= 0, finite, below 2^31 - 1 s, i.e. before 2038; otherwise time 0).
builtin_interfaces::msg::Time ros_time(double seconds);
/// Seconds of a ROS time. RosMessageError "bad_stamp" for a negative sec (ROS 2 times are not
/// negative; rclcpp refuses them) or a nanosec >= 1e9.
double seconds_of(const builtin_interfaces::msg::Time& t);

/// A LaserScan as esfleet's scan (stamp = header stamp, no odometry). Checks, each refusal
/// with its kind:
///  - scan_bad_angles: angle_min, angle_max or angle_increment not finite, |angle_min| or
///    |angle_max| > 2 pi, increment 0 or |increment| > 1 rad;
///  - scan_too_many_beams: more than kMaxRosScanBeams ranges, or fewer than 2;
///  - scan_ranges_mismatch: the angles say n = (angle_max - angle_min) / increment + 1 beams
///    and ranges holds a count more than one beam away from it (drivers round angle_max);
///  - scan_bad_range_limits: range_min, range_max not finite or not 0 <= range_min < range_max;
///  - bad_stamp: a negative sec or a nanosec >= 1e9.
/// Readings that are NaN, infinite, below range_min or at or above range_max are no-return
/// readings (set to range_max, which becomes LaserScan::max_range). Negative increments
/// (upside-down lasers) are kept as they are.
LaserScan scan_from_ros(const sensor_msgs::msg::LaserScan& m);
/// esfleet's scan as a LaserScan in frame `frame` (range_min 0, range_max = max_range,
/// angle_max = angle_min + (n - 1) increment, readings as they are); scan_from_ros gives the
/// same scan back, except that readings above max_range come back as max_range (both are
/// no-returns).
sensor_msgs::msg::LaserScan scan_to_ros(const LaserScan& scan, const std::string& frame);

/// The planar pose of a ROS pose: x, y and the yaw of the quaternion (normalised first).
/// RosMessageError "bad_pose" for a non-finite position or a quaternion that is not finite or
/// has norm < 1e-6.
Pose2 pose2_from_ros(const geometry_msgs::msg::Pose& p);
geometry_msgs::msg::Pose pose2_to_ros(const Pose2& p);
/// The same for a transform (RosMessageError "bad_transform").
Pose2 pose2_from_ros(const geometry_msgs::msg::Transform& t);

/// An odometry message's pose and stamp ("bad_odom" for a bad pose, see pose2_from_ros).
TimedPose odom_from_ros(const nav_msgs::msg::Odometry& m);
nav_msgs::msg::Odometry odom_to_ros(const TimedPose& pose, const std::string& odom_frame,
                                    const std::string& base_frame);

/// The transform parent -> child at `stamp` that places `child_in_parent`.
geometry_msgs::msg::TransformStamped transform_to_ros(double stamp, const std::string& parent,
                                                      const std::string& child,
                                                      const Pose2& child_in_parent);

/// A pose with a diagonal covariance: sigma_xy^2 on x and y, sigma_theta^2 on yaw, tiny
/// values on z, roll and pitch (they are fixed in 2D).
geometry_msgs::msg::PoseWithCovarianceStamped pose_cov_to_ros(const TimedPose& pose,
                                                              const std::string& frame,
                                                              double sigma_xy, double sigma_theta);

/// A pose hint (/initialpose, as RViz2's "2D Pose Estimate" sends it).
struct RosPoseHint {
  std::string frame;
  double stamp = 0.0;
  Pose2 pose;
  double sigma_xy = 0.0;     ///< sqrt of the larger of the x and y variances, metres
  double sigma_theta = 0.0;  ///< sqrt of the yaw variance, radians
};
/// RosMessageError "bad_initialpose" for a bad pose or a covariance diagonal (x, y, yaw) that
/// is negative or not finite.
RosPoseHint hint_from_ros(const geometry_msgs::msg::PoseWithCovarianceStamped& m);

/// The window of the map that /map carries: the bounding box of the map's tiles (it grows by
/// whole tiles, so its geometry changes rarely). Cell (0, 0) of the ROS grid is cell `min`.
struct RosGridWindow {
  CellIndex min{0, 0};
  std::int32_t width = 0;  ///< cells; 0 for an empty map
  std::int32_t height = 0;
  friend bool operator==(const RosGridWindow&, const RosGridWindow&) = default;
  /// Whether `other` lies inside this window.
  bool contains(const RosGridWindow& other) const;
};
/// The window of all the map's tiles.
RosGridWindow map_window(const GridMap& map);
/// The window of the tiles `keys` (non-empty).
RosGridWindow tiles_window(const GridMap& map, const std::vector<TileKey>& keys);

/// The map as an OccupancyGrid over `window`: every cell's ros_cell_value (the values map.pgm
/// reads back as), origin at the window's lower-left corner, frame `frame`.
nav_msgs::msg::OccupancyGrid grid_to_ros(const GridMap& map, const RosGridWindow& window,
                                         const OccupancyThresholds& th, double stamp,
                                         const std::string& frame);
/// The cells of `rect` (inside `window`, the window of the last OccupancyGrid) as an update in
/// that grid's cell coordinates.
map_msgs::msg::OccupancyGridUpdate update_to_ros(const GridMap& map, const RosGridWindow& window,
                                                 const RosGridWindow& rect,
                                                 const OccupancyThresholds& th, double stamp,
                                                 const std::string& frame);

}  // namespace esfleet::dds
