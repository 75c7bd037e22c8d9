#pragma once
// /initialpose for the follower (geometry_msgs/PoseWithCovarianceStamped, what RViz2's "2D Pose
// Estimate" sends): a pose hint, as AMCL takes it. The covariance gives the search window:
// radius 2 sigma_xy (at least 0.1 m), angle 2 sigma_yaw (5 to 180 deg); RViz2's default
// covariance (0.25 m^2, 0.0685 rad^2) gives 1 m and 30 deg. The DDS callback only queues;
// take() checks on the application thread: a pose that is not finite, a bad covariance or a
// frame other than the map's is dropped, counted by kind and logged once per sender and kind.

#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "esfleet/core/global_search.hpp"
#include "esfleet/dds/ros.hpp"

namespace esfleet::follower {

/// The search window of a hint with these standard deviations (see the file comment).
PoseHint hint_window(const Pose2& pose, double sigma_xy, double sigma_theta);

class InitialPoseInput {
 public:
  /// Subscribes to `topic` (a fully qualified ROS name) on `node`; hints must be in `map_frame`.
  InitialPoseInput(dds::Node& node, const std::string& topic, std::string map_frame);
  ~InitialPoseInput();

  /// The newest valid hint that arrived since the last call, if any.
  std::optional<PoseHint> take();
  /// stats.json "initialpose": received, used, dropped by kind.
  nlohmann::json json() const;

 private:
  void drop(const std::string& kind, const std::string& sender, const std::string& why);

  std::string map_frame_;
  std::uint64_t used_ = 0;  ///< main thread only
  std::map<std::string, std::uint64_t> dropped_;
  std::set<std::pair<std::string, std::string>> logged_;

  mutable std::mutex mutex_;
  std::deque<std::pair<geometry_msgs::msg::PoseWithCovarianceStamped, std::string>> queue_;
  std::uint64_t received_ = 0;
  std::unique_ptr<dds::RosPoseReader> reader_;  ///< last: destroyed first
};

}  // namespace esfleet::follower
