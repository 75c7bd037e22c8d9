#pragma once
// esfleet-follower as one object: the constructor sets the robot up step by step (its own
// scans from a log -> DDS participant -> map subscriber -> scan topic -> pose writer) and fails
// naming the step; run() keeps the replica of the leader's map up to date, watches the leader,
// localises and tracks the robot scan by scan (tiles keep arriving between scans) and publishes
// its pose, until its scans end, the map is complete (without scans), the timeout or a signal;
// then it saves. The destructor tears down in reverse (readers and writers before the
// participant).

#include <atomic>
#include <chrono>
#include <memory>
#include <string>

#include "app/ros_pose_output.hpp"
#include "app/ros_scan_source.hpp"
#include "app/scan_source.hpp"
#include "contributor.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/writer.hpp"
#include "follower_options.hpp"
#include "initial_pose_input.hpp"
#include "leader_watch.hpp"
#include "map_subscriber.hpp"
#include "self_localisation.hpp"

namespace esfleet::follower {

class FollowerApp {
 public:
  /// `stop` (SIGINT/SIGTERM) ends the run; SIGUSR1 saves the map without stopping. Throws
  /// app::UsageError naming the step: an unreadable log or --first-scan past its end, a DDS
  /// participant or endpoint that cannot be created.
  FollowerApp(FollowerOptions options, const std::atomic<bool>& stop);
  ~FollowerApp();
  FollowerApp(const FollowerApp&) = delete;
  FollowerApp& operator=(const FollowerApp&) = delete;

  /// Returns the exit code: 0 done, 1 the map or trajectory could not be saved, 3 --timeout.
  int run();

 private:
  double seconds_since_start() const;
  /// One pass of the loop; false when the run is over.
  bool spin();
  /// Runs the next scan if one is due; false when the scans have ended.
  bool next_scan();
  void watch_leader();
  /// The ROS 2 scan source (--ros-scan) and outputs (--ros); inside the DDS setup step.
  void open_ros();
  /// After a scan: the pose and TF for ROS 2 tools, while tracking.
  void publish_ros_pose(const LaserScan& scan, const LocaliserStep& step);
  /// --contribute, after the scans: waits (bounded) for the leader's answer to the last
  /// contribution and for its map with it, so that the saved map is the leader's final one.
  void settle_contributions();
  void warn_no_map() const;
  void report() const;
  /// Saves the map files, stats.json and the trajectory; false on any failure.
  bool save(const char* why) const;
  /// Not tracking and the leader's final map still arriving: the scan waits for it (at most
  /// kMapArrivalGraceS, then it localises in what is here).
  bool hold_for_map();
  nlohmann::json stats_json(const char* why) const;

  FollowerOptions o_;
  const std::atomic<bool>& stop_;
  std::chrono::steady_clock::time_point start_;
  std::unique_ptr<app::ScanSource> source_;
  std::unique_ptr<dds::Node> node_;
  std::unique_ptr<MapSubscriber> map_;
  app::TopicScanSource* topic_ = nullptr;   ///< source_ when it is the scan topic
  app::RosScanSource* ros_scan_ = nullptr;  ///< source_ when it is a ROS scan topic
  std::unique_ptr<dds::PoseWriter> pose_writer_;
  std::unique_ptr<app::RosPoseOutput> ros_pose_;    ///< --ros
  std::unique_ptr<InitialPoseInput> initial_pose_;  ///< --ros
  std::unique_ptr<Contributor> contributor_;        ///< --contribute
  SelfLocalisation localisation_;
  LeaderWatch leader_;
  double first_tile_s_ = -1.0;
  double complete_s_ = -1.0;
  /// Localisation held while the final map arrives (MapReplica::arriving): since when, and
  /// the scans held.
  double holding_since_s_ = -1.0;
  std::uint64_t scans_held_ = 0;
  bool warned_map_grace_ = false;
  bool warned_no_map_ = false;
  bool timed_out_ = false;
  bool scans_ended_ = false;
  std::chrono::steady_clock::time_point last_report_;
  std::uint64_t dropped_tracking_ = 0;   ///< topic scans skipped while tracking
  std::vector<double> tracking_lag_ms_;  ///< topic scans: arrival to pose published, tracking
};

}  // namespace esfleet::follower
