#pragma once
// A robot's pose for ROS 2 tools: geometry_msgs/PoseWithCovarianceStamped on <ns>/pose
// (reliable, transient-local, depth 1, as AMCL's amcl_pose) and TF on /tf: map -> <ns>/odom
// when the robot has odometry (REP 105: map -> odom -> base_link), else map -> <ns>/base_link.

#include <cstdint>
#include <optional>
#include <string>

#include "app/ros_options.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/dds/ros.hpp"

namespace esfleet::app {

/// How sure a pose is, as a covariance: standard deviations in x/y (m) and yaw (rad).
struct PoseSigma {
  double xy = 0.0;
  double theta = 0.0;
};

/// The pose uncertainty esfleet reports from how well the scan agreed with the map (the share
/// of its end points in observed cells that hit occupied ones, FitnessValue::agreement): a
/// tracked pose whose scan agrees fully is good to about a cell (sigma_xy = cell size, 1 deg);
/// each missing tenth of agreement adds 10 cm and 2 deg. A robot that is not tracking
/// (localising, lost) reports sigma_xy 100 m and sigma_yaw pi: "anywhere".
PoseSigma pose_sigma(bool tracking, double agreement, double cell_size);

class RosPoseOutput {
 public:
  /// Creates the pose and /tf writers on `node` (which must outlive this object). Throws
  /// std::runtime_error if DDS refuses.
  RosPoseOutput(dds::Node& node, const RosNames& names);

  /// Publishes the laser's pose in the map at the scan time: the base's pose (laser_in_map ⊕
  /// mount⁻¹) on <ns>/pose and the TF. `laser_odometry`: the scan's odometry (of the laser,
  /// as RosScanSource hands it out), if the robot has odometry.
  void publish(const TimedPose& laser_in_map, const std::optional<Pose2>& laser_odometry,
               const Pose2& mount, const PoseSigma& sigma);

  std::uint64_t poses_published() const { return pose_.samples_written(); }
  std::uint64_t bytes_written() const { return pose_.bytes_written() + tf_.bytes_written(); }

 private:
  RosNames names_;
  dds::RosPoseWriter pose_;
  dds::RosTfWriter tf_;
};

}  // namespace esfleet::app
