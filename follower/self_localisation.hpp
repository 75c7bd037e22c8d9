#pragma once
// The follower robot's own localisation in the shared map, one scan at a time: the Localiser
// (core) run against the replica's map as it is at each scan, plus what the follower reports of
// it (stats.json "localisation", the tracked trajectory, the log lines at a declared pose and
// at a loss). When the leader starts a new map (a new epoch) it localises afresh.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/localiser.hpp"
#include "esfleet/mapshare/map_replica.hpp"

namespace esfleet::follower {

/// What the follower's localisation did (stats.json "localisation").
struct LocalisationStats {
  std::size_t scans = 0;
  std::size_t scans_waiting_for_map = 0;
  std::size_t declarations = 0;
  std::size_t lost_events = 0;
  std::size_t global_searches = 0;
  double cpu_s_total = 0.0;
  double cpu_s_to_first_pose = -1.0;  ///< CPU from the first scan with a map to the declaration
  std::size_t scans_to_first_pose = 0;
  std::optional<TimedPose> first_pose;
  std::vector<double> tracking_cpu_ms;  ///< per tracked scan (not the declaring one)
};

class SelfLocalisation {
 public:
  explicit SelfLocalisation(LocaliserConfig config) : localiser_(std::move(config)) {}

  /// Localises `scan` in the replica's map (waiting while there is none).
  LocaliserStep process(const mapshare::MapReplica& replica, const LaserScan& scan);

  LocaliserState state() const { return localiser_.state(); }
  /// Localise afresh around `hint` (/initialpose); see Localiser::set_hint.
  void set_hint(const PoseHint& hint) { localiser_.set_hint(hint); }
  /// Forget the pose and search globally again (Localiser::reset): the leader keeps refusing
  /// this robot's contributed scans, so its pose is likely wrong. Counted (resets()).
  void reset();
  /// reset() calls so far.
  std::size_t resets() const { return resets_; }
  /// The last step (default before the first scan).
  const LocaliserStep& last_step() const { return last_; }
  const LocalisationStats& stats() const { return stats_; }
  /// One pose per scan processed while tracking.
  const std::vector<TimedPose>& trajectory() const { return trajectory_; }
  /// stats.json "localisation" (without the scan topic's figures).
  nlohmann::json json(const std::string& robot_id) const;

 private:
  Localiser localiser_;
  LocalisationStats stats_;
  std::vector<TimedPose> trajectory_;
  LocaliserStep last_;
  std::optional<std::uint32_t> epoch_;  ///< of the map localised in
  double cpu_s_localising_ = 0.0;       ///< since localising (re)started
  std::size_t scans_localising_ = 0;
  std::size_t resets_ = 0;
};

/// The pose topic's status code of a localiser state.
std::uint8_t status_of(LocaliserState s);

}  // namespace esfleet::follower
