#include "ros_replay_writer.hpp"

#include <algorithm>
#include <utility>

#include "esfleet/dds/ros_msg.hpp"

namespace esfleet::sim {

namespace {

tf2_msgs::msg::TFMessage tf_message(geometry_msgs::msg::TransformStamped t) {
  tf2_msgs::msg::TFMessage m;
  m.transforms().push_back(std::move(t));
  return m;
}

}  // namespace

RosReplayWriter::RosReplayWriter(dds::Node& node, Config config)
    : c_(std::move(config)),
      scan_topic_(dds::ros_name(c_.ns, "scan")),
      odom_topic_(dds::ros_name(c_.ns, "odom")),
      odom_frame_(dds::ros_frame(c_.ns, c_.odom_frame)),
      base_frame_(dds::ros_frame(c_.ns, c_.base_frame)),
      laser_frame_(dds::ros_frame(c_.ns, c_.laser_frame)) {
  tf_static_ = std::make_unique<dds::RosTfWriter>(node, dds::ros_tf_static_endpoint(false));
  if (c_.odometry) {
    tf_ = std::make_unique<dds::RosTfWriter>(node, dds::ros_tf_endpoint());
    odom_ = std::make_unique<dds::RosOdomWriter>(node, dds::ros_odom_endpoint(odom_topic_, false));
  }
  scan_ = std::make_unique<dds::RosScanWriter>(node, dds::ros_scan_endpoint(scan_topic_, false));
}

RosReplayWriter::~RosReplayWriter() = default;

bool RosReplayWriter::publish_static(double stamp) {
  return tf_static_->write(
      tf_message(dds::transform_to_ros(stamp, base_frame_, laser_frame_, c_.laser_pose)));
}

bool RosReplayWriter::publish(const LaserScan& scan) {
  bool ok = true;
  if (odom_ && scan.odometry) {
    const TimedPose pose{scan.stamp, *scan.odometry};
    ok &= odom_->write(dds::odom_to_ros(pose, odom_frame_, base_frame_));
    ok &= tf_->write(
        tf_message(dds::transform_to_ros(scan.stamp, odom_frame_, base_frame_, *scan.odometry)));
  }
  ok &= scan_->write(dds::scan_to_ros(scan, laser_frame_));
  return ok;
}

int RosReplayWriter::matched_scan_readers() const { return scan_->matched_readers(); }

bool RosReplayWriter::wait_for_scan_readers(int count, std::chrono::milliseconds timeout) const {
  return scan_->wait_for_matched(count, timeout);
}

bool RosReplayWriter::wait_for_acknowledgments(std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  auto left = [&] {
    return std::max(std::chrono::milliseconds(0),
                    std::chrono::duration_cast<std::chrono::milliseconds>(
                        deadline - std::chrono::steady_clock::now()));
  };
  bool all = scan_->wait_for_acknowledgments(left());
  if (odom_) {
    all = odom_->wait_for_acknowledgments(left()) && all;
    all = tf_->wait_for_acknowledgments(left()) && all;
  }
  return tf_static_->wait_for_acknowledgments(left()) && all;
}

std::uint64_t RosReplayWriter::scans_written() const { return scan_->samples_written(); }

std::uint64_t RosReplayWriter::odometry_written() const {
  return odom_ ? odom_->samples_written() : 0;
}

std::uint64_t RosReplayWriter::write_failures() const {
  return scan_->write_failures() + tf_static_->write_failures() +
         (odom_ ? odom_->write_failures() + tf_->write_failures() : 0);
}

std::uint64_t RosReplayWriter::bytes_written() const {
  return scan_->bytes_written() + tf_static_->bytes_written() +
         (odom_ ? odom_->bytes_written() + tf_->bytes_written() : 0);
}

}  // namespace esfleet::sim
