#pragma once
// The ROS 2 topics esfleet speaks (docs/ros2.md): ROS names as DDS topic names, the QoS ROS 2
// tools use on each, and typed writers and readers of the ROS 2 message types of idl/ros2.idl.
// A ROS 2 node is a DDS participant: ROS topic /a/b is DDS topic "rt/a/b" of type
// <pkg>::msg::dds_::<Name>_, keyless, classic CDR, in the default partition.
//
// Topic and QoS (reliable unless said; KEEP_LAST depth), as the ROS tools that use them:
//   /map          OccupancyGrid        transient-local, 1  (nav2 map_server, slam_toolbox)
//   /map_updates  OccupancyGridUpdate  volatile, 16        (RViz2 Map display's update topic)
//   <ns>/pose     PoseWithCovarianceStamped  transient-local, 1 (AMCL's amcl_pose)
//   <ns>/initialpose  PoseWithCovarianceStamped  volatile, 1 (RViz2 "2D Pose Estimate")
//   /tf           TFMessage            volatile, 100       (tf2_ros)
//   /tf_static    TFMessage            transient-local, 1 written, 100 read (tf2_ros)
//   <ns>/scan     LaserScan            best-effort, 5 read (sensor data: matches best-effort
//                                      drivers and reliable bag players); reliable, 50 written
//   <ns>/odom     Odometry             best-effort, 50 read; reliable, 50 written

#include <stdexcept>
#include <string>
#include <string_view>

#include <esfleet/msg/ros2.h>

#include "esfleet/dds/reader.hpp"
#include "esfleet/dds/topics.hpp"
#include "esfleet/dds/writer.hpp"

namespace esfleet::dds {

/// A ROS name that breaks ROS 2's naming rules (docs/ros2.md).
class RosNameError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// The fully qualified ROS name of `name` in namespace `ns`: an absolute name ("/map") stays as
/// it is, a relative one ("scan") goes under the namespace ("/robot1" -> "/robot1/scan"; "" or
/// "/" -> "/scan"). Both must follow ROS 2's rules: tokens of letters, digits and '_' that do
/// not start with a digit, separated by single '/', no trailing '/' (the namespace "/" aside).
/// The namespace is checked even for an absolute name. Throws RosNameError naming the
/// offending name.
std::string ros_name(std::string_view ns, std::string_view name);

/// The DDS topic of a fully qualified ROS name: "rt" + name ("/map" -> "rt/map").
std::string ros_dds_topic(std::string_view full_name);

/// A TF frame id under namespace `ns`: "odom" in "/robot1" -> "robot1/odom", in "/" -> "odom"
/// (tf2 frame ids carry no leading '/'; one given is dropped). Both follow ros_name's rules;
/// throws RosNameError naming the offending one.
std::string ros_frame(std::string_view ns, std::string_view frame);

/// The endpoints (DDS topic + QoS, see the table above) of the ROS topics; `full_name` is a
/// fully qualified ROS name (ros_name).
TopicQos ros_map_endpoint(std::string_view full_name = "/map");
TopicQos ros_map_updates_endpoint(std::string_view full_name = "/map_updates");
TopicQos ros_pose_endpoint(std::string_view full_name);
TopicQos ros_initialpose_endpoint(std::string_view full_name);
TopicQos ros_tf_endpoint();
/// /tf_static; the reader keeps up to 100 (one per static broadcaster), the writer 1.
TopicQos ros_tf_static_endpoint(bool reader);
/// Scans: best-effort 5 for readers, reliable 50 for writers (esfleet-replay --ros).
TopicQos ros_scan_endpoint(std::string_view full_name, bool reader);
/// Odometry: best-effort 50 for readers, reliable 50 for writers.
TopicQos ros_odom_endpoint(std::string_view full_name, bool reader);

extern template class Writer<nav_msgs::msg::OccupancyGrid>;
extern template class Writer<map_msgs::msg::OccupancyGridUpdate>;
extern template class Writer<geometry_msgs::msg::PoseWithCovarianceStamped>;
extern template class Writer<tf2_msgs::msg::TFMessage>;
extern template class Writer<sensor_msgs::msg::LaserScan>;
extern template class Writer<nav_msgs::msg::Odometry>;
extern template class Reader<nav_msgs::msg::OccupancyGrid>;
extern template class Reader<map_msgs::msg::OccupancyGridUpdate>;
extern template class Reader<geometry_msgs::msg::PoseWithCovarianceStamped>;
extern template class Reader<tf2_msgs::msg::TFMessage>;
extern template class Reader<sensor_msgs::msg::LaserScan>;
extern template class Reader<nav_msgs::msg::Odometry>;

using RosMapWriter = Writer<nav_msgs::msg::OccupancyGrid>;
using RosMapUpdateWriter = Writer<map_msgs::msg::OccupancyGridUpdate>;
using RosPoseWriter = Writer<geometry_msgs::msg::PoseWithCovarianceStamped>;
using RosTfWriter = Writer<tf2_msgs::msg::TFMessage>;
using RosScanWriter = Writer<sensor_msgs::msg::LaserScan>;
using RosOdomWriter = Writer<nav_msgs::msg::Odometry>;
using RosMapReader = Reader<nav_msgs::msg::OccupancyGrid>;
using RosMapUpdateReader = Reader<map_msgs::msg::OccupancyGridUpdate>;
using RosPoseReader = Reader<geometry_msgs::msg::PoseWithCovarianceStamped>;
using RosTfReader = Reader<tf2_msgs::msg::TFMessage>;
using RosScanReader = Reader<sensor_msgs::msg::LaserScan>;
using RosOdomReader = Reader<nav_msgs::msg::Odometry>;

}  // namespace esfleet::dds
