#pragma once
// esfleet-leader as one object: the constructor sets the run up step by step (resumed
// checkpoint -> the log's scans -> DDS participant -> map publisher -> scan topic ->
// checkpoints) and fails naming the step; run() maps every scan, publishes the changed tiles
// every publish period, checkpoints, writes the results and serves the map until it is told to
// stop; the destructor tears down in reverse (the scan reader and the writers before the DDS
// participant).
//
// With --accept-contributions a ContributionIntake checks the scans followers contribute after
// every own scan and while serving; what they change is published like the leader's own scans,
// and the outputs are written again after serving if they changed the map.
//
// With --map (a map server) the constructor loads the saved map instead (load_map) and opens
// DDS; run() publishes it at once, complete, and serves it (serve_map): the summary every
// publish period (and any tile a late joiner needs), /map every ROS map period, all in wall
// time, until stopped or --linger. No SLAM runs.

#include <atomic>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "app/ros_pose_output.hpp"
#include "app/ros_scan_source.hpp"
#include "app/scan_source.hpp"
#include "checkpoint.hpp"
#include "contribution_intake.hpp"
#include "esfleet/core/slam.hpp"
#include "esfleet/dds/node.hpp"
#include "leader_options.hpp"
#include "map_publisher.hpp"
#include "ros_map_output.hpp"
#include "served_map.hpp"
#include "slam_run.hpp"

namespace esfleet::leader {

class LeaderApp {
 public:
  /// `stop` (set by SIGINT/SIGTERM) ends the mapping and the serving early. Throws
  /// app::UsageError naming the step and the cause: a checkpoint that cannot be resumed, a log
  /// that cannot be read, a saved map (--map) that cannot be loaded or an --out that is its own
  /// directory, a DDS participant or endpoint that cannot be created, a checkpoint directory
  /// that cannot be written.
  LeaderApp(LeaderOptions options, const std::atomic<bool>& stop);
  ~LeaderApp();
  LeaderApp(const LeaderApp&) = delete;
  LeaderApp& operator=(const LeaderApp&) = delete;

  /// Maps, publishes, writes the results and serves the map. Returns the exit code: 0 done,
  /// 1 the results could not be written or no scan came, 130 interrupted. A map server
  /// (--map) returns 0 when stopped or at the end of --linger, 1 if its outputs could not be
  /// written.
  int run();

 private:
  void resume_checkpoint();
  /// --map: loads the saved map (served_map.hpp), takes its map id, checks --out.
  void load_map();
  /// --map: publishes the saved map at once and serves it; returns the exit code.
  int serve_map();
  /// --map: publishes the tiles that need it and the summary (`tiles`), /map (`ros`, --ros);
  /// returns the number of tiles handed over.
  std::size_t publish_served(bool tiles, bool ros);
  /// --map: stats.json of the map server.
  nlohmann::json served_stats(double served_s, const char* ended) const;
  void read_log();
  void open_dds();
  /// The ROS 2 scan source (--ros-scan) and outputs (--ros).
  void open_ros();
  void open_checkpoints();
  /// After each scan: checkpoint, publish when due, progress line.
  void on_scan(const LaserScan& scan, const SlamStep& step, std::size_t done);
  void publish(bool complete, float fitness);
  /// What stats.json holds besides the SLAM's own figures.
  nlohmann::json extra_stats(const SlamRunStats& stats);
  /// stats.json "ros": what the ROS outputs sent and cost; logs a summary.
  nlohmann::json ros_stats(const SlamRunStats& stats) const;
  /// After a complete map: serves it for --linger seconds or until stopped; with
  /// --accept-contributions checks the contributions every 50 ms and publishes what they
  /// changed. Returns the contributions accepted meanwhile.
  std::size_t serve(const SlamRunStats& stats);
  /// Writes the map files and stats.json; false (logged) on failure.
  bool write_outputs(const SlamRunStats& stats);

  LeaderOptions o_;
  const std::atomic<bool>& stop_;
  std::string params_json_;  ///< the parameters as JSON text (checkpoints, the map summary)
  Slam slam_;
  std::optional<Resumed> resumed_;
  std::optional<ServedMap> served_;  ///< --map
  std::unique_ptr<dds::Node> node_;
  std::unique_ptr<MapPublisher> publisher_;
  std::unique_ptr<ContributionIntake> intake_;  ///< --accept-contributions
  std::unique_ptr<app::ScanSource> source_;
  app::TopicScanSource* topic_ = nullptr;   ///< source_ when it is the scan topic
  app::RosScanSource* ros_scan_ = nullptr;  ///< source_ when it is a ROS scan topic
  std::unique_ptr<RosMapOutput> ros_map_;   ///< --ros
  std::unique_ptr<app::RosPoseOutput> ros_pose_;
  double ros_pose_cpu_s_ = 0.0;  ///< thread CPU of the pose and TF outputs
  std::optional<CheckpointSchedule> checkpoints_;
  std::optional<SlamFinish> final_pass_;  ///< what Slam::finish did at the end of the input
  std::size_t progress_every_ = 0;
  std::optional<double> first_stamp_;
  double last_stamp_ = 0.0;
  double last_publish_ = -1e300;
};

}  // namespace esfleet::leader
