#include "app/ros_pose_output.hpp"

#include <algorithm>
#include <numbers>

#include "esfleet/dds/ros_msg.hpp"

namespace esfleet::app {

PoseSigma pose_sigma(bool tracking, double agreement, double cell_size) {
  if (!tracking) return PoseSigma{100.0, std::numbers::pi};
  const double missing = std::clamp(1.0 - agreement, 0.0, 1.0);
  return PoseSigma{cell_size + missing * 1.0, deg_to_rad(1.0 + missing * 20.0)};
}

RosPoseOutput::RosPoseOutput(dds::Node& node, const RosNames& names)
    : names_(names),
      pose_(node, dds::ros_pose_endpoint(names.pose_topic)),
      tf_(node, dds::ros_tf_endpoint()) {}

void RosPoseOutput::publish(const TimedPose& laser_in_map,
                            const std::optional<Pose2>& laser_odometry, const Pose2& mount,
                            const PoseSigma& sigma) {
  const Pose2 to_base = mount.inverse();
  const TimedPose base{laser_in_map.stamp, laser_in_map.pose.compose(to_base)};
  pose_.write(dds::pose_cov_to_ros(base, names_.map_frame, sigma.xy, sigma.theta));
  tf2_msgs::msg::TFMessage tf;
  if (laser_odometry) {
    const Pose2 base_in_odom = laser_odometry->compose(to_base);
    tf.transforms().push_back(dds::transform_to_ros(base.stamp, names_.map_frame, names_.odom_frame,
                                                    base.pose.compose(base_in_odom.inverse())));
  } else {
    tf.transforms().push_back(
        dds::transform_to_ros(base.stamp, names_.map_frame, names_.base_frame, base.pose));
  }
  tf_.write(tf);
}

}  // namespace esfleet::app
