#pragma once
// esfleet-fleet's application: a simulated fleet on this host. Starts a leader that maps --log
// and shares the map, the simulator with N robots in --world and one follower per robot; watches
// what the robots say (pose topic) against where the simulator put them (truth topic), shows it
// in a status table, stops everything in order and writes the summary.
//
// Life cycle: the constructor checks the world, makes the output directories, creates the DDS
// participant and the launcher's readers and names the children (nothing is started yet); run()
// starts the programs, watches them until --duration, --window, Ctrl-C or a failure, stops them
// (simulator, followers, leader) and writes the summary; the destructor stops any child still
// running (run() threw), then deletes the readers before the participant.

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/reader.hpp"
#include "fleet_monitor.hpp"
#include "fleet_options.hpp"
#include "fleet_summary.hpp"
#include "status_table.hpp"

namespace esfleet::fleet {

class FleetApp {
 public:
  /// `options` must have passed validate(); `stop` is the SIGINT/SIGTERM flag. Throws
  /// app::UsageError naming the step that failed: the world map, an output directory, the DDS
  /// participant or one of its readers.
  FleetApp(FleetOptions options, const std::atomic<bool>& stop);
  ~FleetApp();
  FleetApp(const FleetApp&) = delete;
  FleetApp& operator=(const FleetApp&) = delete;

  /// Runs the fleet once. Returns 0 when it ran as asked (also when stopped by Ctrl-C), 1 when
  /// a program could not start or exited early (the summary says which) or the summary could
  /// not be written.
  int run();

 private:
  using Clock = std::chrono::steady_clock;

  bool stopping() const { return stop_.load() || abort_; }
  double now_s() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }
  /// Logs `why`, keeps it as the run's failure and ends the run.
  void fail(const std::string& why);
  std::optional<MapProgress> map_progress() const;
  /// The simulator, the followers, the leader: the order they are sampled and listed in.
  std::vector<ChildProcess*> children();

  void start_leader();
  /// --wait-map: until the leader's map is complete (or the leader exits, --duration passes,
  /// Ctrl-C).
  void wait_for_map();
  void start_robots();
  /// The monitoring loop: feeds the monitor, samples the children every second, starts the
  /// real-time window, redraws the table; returns at the end of the run.
  void watch();
  /// Once a second: samples, starts the window when all track. False when a child has exited.
  bool check_children(double dt_s);
  /// A leader that died is started again (--max-leader-restarts), from its checkpoint if any.
  void restart_leader();
  void draw(double dt_s);
  void stop_children();
  /// Writes the summary and prints its line; the exit code.
  int finish(const FleetTimes& times);

  FleetOptions o_;
  const std::atomic<bool>& stop_;
  std::string bin_dir_;  ///< where the programs are (--bin-dir resolved)
  bool abort_ = false;   ///< the run ends early (failure_ says why)
  std::string failure_;  ///< why the run ended early; empty = it ran as asked
  Clock::time_point start_ = Clock::now();
  double followers_start_s_ = 0.0;
  double window_start_s_ = -1.0;

  // Filled by the DDS callbacks, emptied by watch() (docs/architecture.md, "Threads").
  mutable std::mutex mutex_;
  std::vector<PoseSample> poses_;
  std::vector<TruthSample> truths_;
  std::optional<MapProgress> map_;

  FleetMonitor monitor_;
  StatusTable table_;
  ChildProcess leader_, sim_;
  ChildProcess view_;  ///< esfleet-view with --view (not in children(): no table row)
  bool view_gone_logged_ = false;
  std::vector<ChildProcess> followers_;

  // Declared last, destroyed first: the readers before the node, both before the queues.
  std::unique_ptr<dds::Node> node_;
  std::unique_ptr<dds::PoseReader> pose_reader_;
  std::unique_ptr<dds::TruthReader> truth_reader_;
  std::unique_ptr<dds::MetaReader> meta_reader_;
};

}  // namespace esfleet::fleet
