#pragma once
// Where scans come from (leader and follower).
//
// A ScanSource hands out scans in order on the application thread: LogScanSource from a
// recorded log (optionally paced at the recorded speed), TopicScanSource from the DDS scan topic
// of one robot. TopicScanSource's DDS callback only appends the received message to a locked
// queue; conversion and everything that touches the SLAM happen on the thread calling next()
// (DDS callbacks never touch application state: docs/architecture.md, "Threads").

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/dds/reader.hpp"

namespace esfleet::app {

class ScanSource {
 public:
  virtual ~ScanSource() = default;
  /// The next scan, blocking until it is due (log) or arrives (topic); std::nullopt once the
  /// source has ended or `stop` is set.
  virtual std::optional<LaserScan> next(const std::atomic<bool>& stop) = 0;
  /// For loops that serve DDS between scans: the next scan if one is ready, std::nullopt at
  /// once otherwise (then ended() tells whether the source has ended).
  virtual std::optional<LaserScan> poll(const std::atomic<bool>& stop) {
    return ready() ? next(stop) : std::nullopt;
  }
  /// True once next() returned std::nullopt because the source ran out by itself (end of the
  /// log, --idle-exit), not because of `stop`.
  virtual bool ended() const = 0;
  /// How many scans the source holds in all; 0 = not known in advance.
  virtual std::size_t total() const { return 0; }
  /// True when next() would return at once (a scan is due or waiting, or the source has ended):
  /// lets a loop that also serves DDS poll the source without blocking.
  virtual bool ready() const = 0;
};

/// The scans of a log in file order: the first max_scans if > 0, fewer if `stop` is set while
/// reading. Warns when odometry is used with a GMapping-corrected log, and when scans are not
/// stamped after the scan before them (esfleet::stamp_order). Throws LogError naming
/// file and line, also for a log without scans.
std::vector<LaserScan> read_log(const std::string& path, const CarmenReaderOptions& options,
                                std::size_t max_scans, bool use_odometry,
                                const std::atomic<bool>& stop);

/// The scans of a log read beforehand, each handed out once (moved out, its memory then the
/// consumer's). With rate > 0, scan i is due (stamp_i - stamp_0) / rate seconds after the first
/// call of next() (1 = recorded speed); with 0, as fast as asked.
class LogScanSource : public ScanSource {
 public:
  LogScanSource(std::vector<LaserScan> scans, double rate);
  std::optional<LaserScan> next(const std::atomic<bool>& stop) override;
  bool ended() const override { return next_ >= scans_.size(); }
  std::size_t total() const override { return scans_.size(); }
  bool ready() const override;

 private:
  /// When scan `i` is due (rate > 0; start_ set).
  std::chrono::steady_clock::time_point due(std::size_t i) const;

  std::vector<LaserScan> scans_;  ///< those before next_ are moved out
  double first_stamp_;
  double rate_;
  std::size_t next_ = 0;
  std::chrono::steady_clock::time_point start_;
};

/// What a TopicScanSource saw.
struct TopicScanStats {
  std::uint64_t received = 0;      ///< messages of our robot (malformed ones included)
  std::uint64_t malformed = 0;     ///< dropped: scan_from_msg refused them
  std::uint64_t other_robots = 0;  ///< messages of other robot ids, ignored
  std::uint64_t seq_gaps = 0;      ///< scans missing according to the seq numbers
  std::uint64_t seq_restarts = 0;  ///< seq went backwards (the publisher restarted)
  std::size_t max_queue = 0;       ///< most scans waiting for the SLAM at once
  std::uint64_t dropped = 0;       ///< skipped by latest_only: a newer scan was waiting
};

/// The scans that robot `robot_id` publishes on the scan topic (dds::kScanTopic) in its own
/// partition (named after the robot id, as every ScanWriter of the programs publishes), in
/// arrival order. next() ends (std::nullopt) when `stop` is set or, with idle_exit_s > 0, once at
/// least one scan arrived and none has arrived for idle_exit_s seconds with the queue empty. A
/// message that scan_from_msg refuses is dropped and counted; the first is logged. With
/// latest_only, next() returns the newest waiting scan and drops (counts) the older ones: a
/// consumer that fell behind (a global localisation takes ~1 s) catches up at once instead of
/// working through a backlog of stale scans. Odometry in the scans is absolute, so a consumer
/// loses no motion information by skipping scans.
class TopicScanSource : public ScanSource {
 public:
  /// Creates the scan reader on `node` (which must outlive this object). Throws
  /// std::runtime_error if DDS refuses.
  TopicScanSource(dds::Node& node, std::string robot_id, double idle_exit_s,
                  bool latest_only = false);
  std::optional<LaserScan> next(const std::atomic<bool>& stop) override;
  /// True once next() ended because no scan arrived for idle_exit_s.
  bool ended() const override { return idle_; }
  bool ready() const override;
  TopicScanStats stats() const;
  int matched_writers() const { return reader_.matched_writers(); }
  /// When the scan last returned by next() arrived (for the consumer's processing lag).
  std::chrono::steady_clock::time_point last_arrival_of_returned() const {
    return returned_arrival_;
  }

 private:
  using Clock = std::chrono::steady_clock;
  /// DDS listener thread: queue the message, nothing else.
  void on_message(const msg::LaserScanMsg& m);
  /// Seq bookkeeping and conversion; std::nullopt (counted, first one logged) if malformed.
  std::optional<LaserScan> convert(const msg::LaserScanMsg& m);

  const std::string robot_id_;
  const double idle_exit_s_;
  const bool latest_only_;
  bool idle_ = false;
  Clock::time_point returned_arrival_;     ///< main thread only
  std::optional<std::uint32_t> last_seq_;  ///< main thread only
  std::uint64_t malformed_ = 0;            ///< main thread only
  std::uint64_t seq_gaps_ = 0;             ///< main thread only
  std::uint64_t seq_restarts_ = 0;         ///< main thread only

  mutable std::mutex mutex_;  ///< guards the members up to the reader
  std::condition_variable arrived_;
  struct Arrived {
    msg::LaserScanMsg msg;
    Clock::time_point at;
  };
  std::deque<Arrived> queue_;
  std::uint64_t dropped_ = 0;
  std::optional<Clock::time_point> last_arrival_;
  std::uint64_t received_ = 0;
  std::uint64_t other_robots_ = 0;
  std::size_t max_queue_ = 0;

  dds::ScanReader reader_;  ///< last: destroyed first, so no callback outlives the queue
};

}  // namespace esfleet::app
