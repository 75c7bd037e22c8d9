#pragma once
// esfleet-replay's application: publishes the laser scans of a recorded CARMEN log on the DDS
// scan topic (esfleet/robots/scan) as one robot, the way its laser driver would: at the
// recorded speed, a multiple of it, or as fast as the readers acknowledge.
//
// No scan is lost, whatever the rate: the scan topic is RELIABLE with KEEP_LAST 50, so a writer
// that ran more than 50 scans ahead of a reader's acknowledgments would drop scans from its
// history before the reader had them (and a reader missing one scan holds the ones after it
// until the repair, in a history of 50 too). The replay therefore never has more than
// kAckWindow scans unacknowledged: after every kAckWindow scans it waits until every matched
// reader has acknowledged all of them. The writer heartbeats every 100 ms, so the pace at
// --rate 0 is about kAckWindow scans per heartbeat round trip.
//
// With --ros it publishes what a ROS 2 robot would instead (ros_replay_writer.hpp): odometry,
// /tf and sensor_msgs/LaserScan per scan under the ROS namespace, /tf_static once; the same
// pacing, and the acknowledgment window over all those writers.
//
// Life cycle: the constructor reads the log, then creates the DDS participant and the scan
// writer (in the robot's partition), or the ROS writers (default partition); run() waits for
// the readers (--wait-subscribers: of the scan topic), sends the scans, waits a bounded time
// for the last acknowledgments and reports; the destructor deletes the writers before the
// participant.

#include <atomic>
#include <chrono>
#include <memory>
#include <vector>

#include "esfleet/core/laser_scan.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/writer.hpp"
#include "replay_options.hpp"
#include "ros_replay_writer.hpp"

namespace esfleet::sim {

class ReplayApp {
 public:
  /// Most scans in flight without acknowledgment; below the topic's KEEP_LAST depth of 50.
  static constexpr std::size_t kAckWindow = 40;

  /// `options` must have passed validate(); `stop` is the SIGINT/SIGTERM flag. Throws
  /// app::UsageError naming what failed: the log (file and line), --first-scan past its end,
  /// the DDS participant or the writer.
  ReplayApp(ReplayOptions options, const std::atomic<bool>& stop);
  ~ReplayApp();
  ReplayApp(const ReplayApp&) = delete;
  ReplayApp& operator=(const ReplayApp&) = delete;

  /// Publishes the scans. Returns 0 when all were sent (also when a reader did not acknowledge
  /// the last ones in time: a warning says so), 130 when stopped by the stop flag.
  int run();

  /// The scans to publish (after --first-scan and --max-scans).
  const std::vector<LaserScan>& scans() const { return scans_; }

 private:
  /// --wait-subscribers: until that many readers matched, --wait-timeout passed or stopped.
  void wait_for_readers();
  /// Sends every scan at the --rate pace (scan i due at its log time since the first, divided
  /// by the rate, after `start`); returns the seconds spent waiting for acknowledgments.
  double send_scans(std::chrono::steady_clock::time_point start);
  /// Waits until the readers acknowledged everything written (see the file comment), checking
  /// the stop flag; returns the seconds waited.
  double wait_for_acks();

  // The writers of either mode: esfleet's scan topic or the ROS topics (--ros).
  int matched_readers() const;
  std::string scan_topic() const;
  bool acknowledged(std::chrono::milliseconds timeout) const;

  ReplayOptions o_;
  const std::atomic<bool>& stop_;
  std::vector<LaserScan> scans_;
  std::uint32_t seq_ = 0;  ///< next scan seq
  // Declared last, destroyed first: the writer before the node (node.hpp).
  std::unique_ptr<dds::Node> node_;
  std::unique_ptr<dds::ScanWriter> writer_;  ///< null with --ros
  std::unique_ptr<RosReplayWriter> ros_;     ///< with --ros only
};

}  // namespace esfleet::sim
