#pragma once
// The leader's side of contributed scans (esfleet-leader --accept-contributions; core
// contribution.hpp): a reader of esfleet/robots/contribution in every partition whose callback
// only queues, and, on the mapping thread, process(): each waiting contribution of the current
// map is checked and, when accepted, written into the map by Slam::contribute; its robot gets a
// ContributionStatus in its own partition. The changed tiles are in the map's dirty set like
// the leader's own scans', so the caller's next publish sends them.
//
// Bounded: at most kMaxQueue samples wait (the oldest is dropped and counted), at most
// dds::kMaxRobots robots are tracked (later ones are ignored and counted).

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "esfleet/core/slam.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/reader.hpp"
#include "esfleet/dds/to_msg.hpp"
#include "esfleet/dds/writer.hpp"
#include "esfleet/mapshare/messages.hpp"

namespace esfleet::leader {

class ContributionIntake {
 public:
  /// Samples waiting for the mapping thread at most; the oldest is dropped beyond.
  static constexpr std::size_t kMaxQueue = 256;
  /// Seconds between a robot's progress lines.
  static constexpr double kLogPeriodS = 10.0;

  /// Creates the reader (partition "*"); contributions for another map id or epoch than `map`
  /// are dropped as stale. Throws std::runtime_error naming the topic if Fast DDS refuses.
  ContributionIntake(dds::Node& node, mapshare::MapIdentity map);
  ~ContributionIntake();
  ContributionIntake(const ContributionIntake&) = delete;
  ContributionIntake& operator=(const ContributionIntake&) = delete;

  /// On the mapping thread: checks every waiting contribution against `slam` in arrival order
  /// and answers its robot. Returns how many were accepted (the map changed if > 0).
  std::size_t process(Slam& slam);
  /// Contributions accepted so far, all robots.
  std::uint64_t accepted() const { return accepted_; }
  /// Logs one line per robot that contributed.
  void log_summary() const;
  /// stats.json "contributions": {robot: {accepted, rejected: {verdict: n}, stale, dropped,
  /// malformed, cpu_ms_median, cpu_ms_p95}}.
  nlohmann::json json() const;

 private:
  struct Robot {
    dds::ContributionTally tally;
    std::map<std::string, std::uint64_t> rejected_by;  ///< verdict name -> count
    std::uint64_t stale = 0;
    std::uint64_t redundant = 0;  ///< skipped: another robot's key scan is already there
    std::uint64_t malformed = 0;
    std::vector<double> cpu_ms;  ///< thread CPU of each Slam::contribute call
    /// In the robot's partition; null when it could not be created (DDS Security).
    std::unique_ptr<dds::ContributionStatusWriter> status;
    std::chrono::steady_clock::time_point last_log;
    std::uint64_t logged = 0;  ///< tally.accepted + tally.rejected at the last line
  };
  void on_sample(const msg::ContributedScan& m);
  /// The robot's entry, created (with its status writer, if Fast DDS allows it) on first use;
  /// nullptr beyond dds::kMaxRobots robots.
  Robot* robot(const std::string& id);
  void handle(Slam& slam, const msg::ContributedScan& m);
  void log_robot(const std::string& id, Robot& r);

  dds::Node& node_;
  mapshare::MapIdentity map_;
  mutable std::mutex mutex_;                      ///< guards queue_ and dropped_
  std::deque<msg::ContributedScan> queue_;        ///< filled by the reader's callback
  std::map<std::string, std::uint64_t> dropped_;  ///< robot -> samples dropped from the queue
  std::map<std::string, Robot> robots_;           ///< mapping thread only
  std::uint64_t accepted_ = 0;
  std::uint64_t ignored_robots_ = 0;                 ///< samples of robots beyond dds::kMaxRobots
  std::unique_ptr<dds::ContributionReader> reader_;  ///< last: its callback uses the above
};

}  // namespace esfleet::leader
