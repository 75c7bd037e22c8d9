#pragma once
// esfleet-view's application: a read-only DDS participant (no writer at all) that keeps a
// replica of the shared map (follower::MapSubscriber, the follower's own code), hears every
// robot's pose (and the simulator's truth, when there is one) and shows them in browsers through
// its WebServer (web_server.hpp).
//
// Threads: the DDS callbacks only queue (MapSubscriber's queue, the pose and truth vectors
// here); the application thread (run) applies the tiles to the replica, encodes the tiles that
// changed (tile_frame.hpp) and posts them, with the robots' and the map's state as JSON, to the
// server, which runs on its own I/O thread and never makes this thread wait. Downloads are made
// here, on the application thread, from the replica (core's ROS map and PNG writers).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "esfleet/core/geometry.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/reader.hpp"
#include "fleet_monitor.hpp"
#include "leader_watch.hpp"
#include "map_subscriber.hpp"
#include "view_options.hpp"
#include "web_server.hpp"

namespace esfleet::view {

class ViewApp {
 public:
  /// Sets up the DDS participant, the map subscriber, the pose and truth readers and the web
  /// server, in that order; throws app::UsageError naming the step that failed.
  ViewApp(ViewOptions options, const std::atomic<bool>& stop);
  ~ViewApp();
  ViewApp(const ViewApp&) = delete;
  ViewApp& operator=(const ViewApp&) = delete;

  /// Serves until stopped (SIGINT/SIGTERM: 130) or --timeout (0).
  int run();

 private:
  using Clock = std::chrono::steady_clock;
  struct Robot {
    fleet::PoseSample pose;
    float fitness = 0.0f;
    bool leader = false;
    double last_s = 0.0;                        ///< view time of the last pose
    std::deque<std::pair<float, float>> trail;  ///< recent positions, oldest first
    std::size_t poses_at_rate = 0;              ///< pose count at the last rate sample
    double rate_since_s = 0.0;                  ///< view time of the last rate sample
    double rate = 0.0;                          ///< poses per second
  };
  struct DownloadRequest {
    std::string name;
    std::function<void(HttpResponse)> done;
  };

  double now_s() const;
  void drain_poses(double now);
  /// Tiles applied since the last call: encoded and posted to the server; a new epoch first
  /// resets the browsers' map.
  void forward_tiles();
  /// Adds what sending the whole map would have cost at this leader publish (bench figures).
  void count_whole_map();
  void send_robots(double now);
  void send_trails();
  void send_status(double now);
  /// The robots, and with `map_too` the whole map when it changed, to Foxglove clients
  /// (foxglove.hpp).
  void send_foxglove(bool map_too);
  void serve_downloads();
  HttpResponse make_download(const std::string& name) const;

  ViewOptions o_;
  const std::atomic<bool>& stop_;
  Clock::time_point start_;

  std::mutex mutex_;  ///< guards the three queues below (DDS and I/O threads push)
  std::vector<std::pair<fleet::PoseSample, float>> pose_queue_;
  std::vector<fleet::TruthSample> truth_queue_;
  std::vector<DownloadRequest> downloads_;

  follower::LeaderWatch watch_;
  fleet::FleetMonitor monitor_;
  static constexpr std::size_t kMaxRobots = 1000;  ///< robot ids shown; more are ignored
  std::map<std::string, Robot> robots_;
  bool robots_full_logged_ = false;
  std::pair<std::uint32_t, std::uint64_t> foxglove_version_{0, 0};  ///< (epoch, tiles forwarded)
  std::vector<TimedPose> leader_path_;
  std::uint32_t epoch_shown_ = 0;
  bool map_shown_ = false;
  std::uint64_t tiles_forwarded_ = 0;
  std::uint64_t tile_bytes_forwarded_ = 0;
  /// Per batch of changed tiles, what sending the whole map would have cost (bench figures).
  std::map<TileKey, std::size_t> frame_bytes_;  ///< the newest frame's size per tile
  std::uint64_t version_counted_ = 0;           ///< the summary's map_version when last counted
  std::uint64_t publishes_seen_ = 0;  ///< leader publishes (summaries) seen with tiles held
  std::uint64_t whole_map_frame_bytes_ = 0;
  std::uint64_t whole_map_grid_bytes_ = 0;
  static constexpr std::size_t kLatencyKept = 10000;
  std::deque<double> forward_latency_ms_;  ///< leader publish -> forwarded to the server

  // DDS: the node first, its readers after (destroyed first).
  std::unique_ptr<dds::Node> node_;
  std::unique_ptr<follower::MapSubscriber> map_;
  std::unique_ptr<dds::PoseReader> poses_;
  std::unique_ptr<dds::TruthReader> truths_;
  // Last: destroyed first, so no browser request reaches a half-destroyed application.
  std::unique_ptr<WebServer> server_;
};

}  // namespace esfleet::view
