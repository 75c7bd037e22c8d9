#pragma once
// esfleet-replay --ros: the ROS 2 topics a robot (or `ros2 bag play`) publishes, written from a
// log's scans. Per scan, in this order: nav_msgs/Odometry on <ns>/odom (frame <odom>, child
// <base>) and the same pose as the tf2_msgs/TFMessage odom -> base on /tf, when odometry is on
// and the scan has odometry; then the sensor_msgs/LaserScan on <ns>/scan (frame <laser>). All
// three carry the scan's log stamp (never the wall clock), so a consumer that looks the scan's
// pose up in tf finds it exactly. Once, before the first scan, /tf_static carries the laser's
// mount base -> laser (transient-local: late joiners get it too).
//
// QoS: the writers' of ros.hpp (reliable; scans and odometry KEEP_LAST 50, /tf 100, /tf_static
// transient-local 1), in the default partition, as ROS 2 nodes use it. Frame ids are put under
// the namespace with dds::ros_frame ("/robot1" + "odom" -> "robot1/odom").

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/ros.hpp"

namespace esfleet::sim {

class RosReplayWriter {
 public:
  struct Config {
    std::string ns = "/";  ///< ROS namespace of the topics and frames ("/" = none)
    std::string odom_frame = "odom";
    std::string base_frame = "base_link";
    std::string laser_frame = "laser";
    Pose2 laser_pose;      ///< the laser in the base frame
    bool odometry = true;  ///< publish odometry and /tf (else scans and /tf_static only)
  };

  /// Creates the writers on `node` (which must outlive this object). Throws dds::RosNameError
  /// for a bad namespace or frame, std::runtime_error naming the topic when DDS refuses a
  /// writer.
  RosReplayWriter(dds::Node& node, Config config);
  ~RosReplayWriter();
  RosReplayWriter(const RosReplayWriter&) = delete;
  RosReplayWriter& operator=(const RosReplayWriter&) = delete;

  /// /tf_static: base -> laser at `stamp` (the log's first stamp). False if DDS refused it.
  bool publish_static(double stamp);
  /// One scan: odometry and /tf (if odometry is on and the scan has some), then the scan.
  /// False if DDS refused any of them (the others are still written).
  bool publish(const LaserScan& scan);

  /// ROS names of the topics ("/robot1/scan") and the frame ids in use ("robot1/odom").
  const std::string& scan_topic() const { return scan_topic_; }
  const std::string& odom_topic() const { return odom_topic_; }
  const std::string& odom_frame() const { return odom_frame_; }
  const std::string& base_frame() const { return base_frame_; }
  const std::string& laser_frame() const { return laser_frame_; }

  /// Readers matched on the scan topic.
  int matched_scan_readers() const;
  /// Blocks until `count` readers are matched on the scan topic or `timeout` passes.
  bool wait_for_scan_readers(int count, std::chrono::milliseconds timeout) const;
  /// Blocks until every matched reliable reader of every topic acknowledged everything
  /// written, or `timeout` passes (for all the writers together); true if all did.
  bool wait_for_acknowledgments(std::chrono::milliseconds timeout) const;

  std::uint64_t scans_written() const;
  std::uint64_t odometry_written() const;  ///< Odometry messages (as many TF messages on /tf)
  std::uint64_t write_failures() const;    ///< refused writes, all topics
  std::uint64_t bytes_written() const;     ///< CDR bytes, all topics

 private:
  Config c_;
  std::string scan_topic_, odom_topic_;
  std::string odom_frame_, base_frame_, laser_frame_;
  std::unique_ptr<dds::RosTfWriter> tf_static_;
  std::unique_ptr<dds::RosTfWriter> tf_;      ///< null without odometry
  std::unique_ptr<dds::RosOdomWriter> odom_;  ///< null without odometry
  std::unique_ptr<dds::RosScanWriter> scan_;
};

}  // namespace esfleet::sim
