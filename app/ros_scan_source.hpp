#pragma once
// Scans from a ROS 2 robot (sensor_msgs/LaserScan) with, optionally, its odometry
// (nav_msgs/Odometry or the odom -> base transform on /tf) interpolated at each scan's stamp,
// and the laser's mounting pose (flag, /tf_static or identity). The DDS callbacks only queue
// what arrives; checks and conversion run on the thread that calls next() (docs/architecture.md,
// "Threads").
//
// Whatever arrives is checked (dds::scan_from_ros and friends, plus the frame and the order of
// stamps). A message that cannot be used is dropped and counted by kind (stats().dropped, in
// stats.json) and logged once per sender and kind; nothing a peer sends can crash or stall the
// source.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/ros_options.hpp"
#include "app/scan_source.hpp"
#include "esfleet/dds/ros.hpp"

namespace esfleet::app {

/// What a RosScanSource saw.
struct RosScanStats {
  std::uint64_t scans_received = 0;
  std::uint64_t scans_used = 0;
  std::uint64_t odometry_received = 0;           ///< odometry messages or odom -> base transforms
  std::uint64_t scans_skipped = 0;               ///< latest_only: a newer scan was waiting
  std::map<std::string, std::uint64_t> dropped;  ///< by kind ("scan_wrong_frame", ...)
  std::string laser_frame;
  std::string mount_from;  ///< "flag", "tf_static", "identity" or "" (not yet known)
  Pose2 mount;
  nlohmann::json json() const;
};

class RosScanSource : public ScanSource {
 public:
  /// Subscribes to the scan topic of `names` (and its odometry and /tf_static as configured).
  /// `idle_exit_s` and `latest_only` as for TopicScanSource. Throws std::runtime_error if DDS
  /// refuses.
  RosScanSource(dds::Node& node, const RosNames& names, const RosOptions& options,
                double idle_exit_s, bool latest_only = false);
  ~RosScanSource() override;

  std::optional<LaserScan> next(const std::atomic<bool>& stop) override;
  /// Like next(), but returns std::nullopt as soon as no usable scan is waiting (a flood of
  /// broken scans never holds the caller).
  std::optional<LaserScan> poll(const std::atomic<bool>& stop) override;
  bool ended() const override { return idle_; }
  bool ready() const override;
  RosScanStats stats() const;
  int matched_writers() const;
  /// The laser's pose on the base (identity until known).
  Pose2 mount() const { return mount_; }
  /// When the scan last returned by next() arrived.
  std::chrono::steady_clock::time_point last_arrival_of_returned() const {
    return returned_arrival_;
  }

 private:
  using Clock = std::chrono::steady_clock;
  struct Arrived {
    sensor_msgs::msg::LaserScan msg;
    std::string sender;
    Clock::time_point at;
  };
  /// Main thread: odometry and static transforms that arrived since the last call.
  void drain_side_queues();
  std::optional<LaserScan> take(const std::atomic<bool>& stop, bool wait);
  /// Main thread: checks one scan (fields, frame, order of stamps); std::nullopt if dropped.
  std::optional<LaserScan> check(const Arrived& a);
  /// Main thread: check() plus the laser mount and the odometry; std::nullopt if dropped.
  std::optional<LaserScan> convert(const Arrived& a);
  /// Main thread: the base's odometry at `stamp`, if the buffer brackets it (or is close).
  std::optional<Pose2> odometry_at(double stamp) const;
  /// Main thread: counts a dropped message and logs the first of its kind per sender.
  void drop(const std::string& kind, const std::string& sender, const std::string& why);
  void add_odometry(const TimedPose& p);
  void on_transforms(const tf2_msgs::msg::TFMessage& m, const std::string& sender, bool is_static);

  const RosNames names_;
  const RosOptions options_;
  const double idle_exit_s_;
  const bool latest_only_;
  bool idle_ = false;
  Clock::time_point returned_arrival_;

  // main thread only
  std::string laser_frame_;
  std::optional<double> last_stamp_;
  std::deque<TimedPose> odometry_;                                ///< base in odom, by stamp
  std::map<std::string, std::pair<std::string, Pose2>> statics_;  ///< child -> (parent, pose)
  Pose2 mount_;
  std::string mount_from_;
  std::map<std::string, std::uint64_t> dropped_;
  std::set<std::pair<std::string, std::string>> logged_;  ///< (sender, kind)
  std::uint64_t used_ = 0;
  std::uint64_t odometry_received_ = 0;
  std::uint64_t skipped_ = 0;  ///< latest_only: valid scans passed over for a newer one

  mutable std::mutex mutex_;  ///< guards the queues below
  std::condition_variable arrived_;
  std::deque<Arrived> scans_;
  std::deque<std::pair<nav_msgs::msg::Odometry, std::string>> odoms_;
  std::deque<std::pair<tf2_msgs::msg::TFMessage, std::string>> tfs_;
  std::deque<std::pair<tf2_msgs::msg::TFMessage, std::string>> tf_statics_;
  std::optional<Clock::time_point> last_arrival_;
  std::uint64_t received_ = 0;

  // last: destroyed first, so no callback outlives the queues
  std::unique_ptr<dds::RosOdomReader> odom_reader_;
  std::unique_ptr<dds::RosTfReader> tf_reader_;
  std::unique_ptr<dds::RosTfReader> tf_static_reader_;
  std::unique_ptr<dds::RosScanReader> scan_reader_;
};

}  // namespace esfleet::app
