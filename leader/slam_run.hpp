#pragma once
// The leader's SLAM loop over a scan source, its statistics, and its result files (map files,
// trajectory, map digest, stats.json).

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/scan_source.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet::leader {

/// A stretch of scans that matched the map poorly: it opens when at least half of the last
/// kWindow scans were weak matches (agreement < 0.5) and closes after kQuiet scans without one.
/// The SLAM has likely lost track there (scans far apart, a fast turn, a place the laser does
/// not see well) and the map from `first` on may be wrong. Scan numbers count from 1 in this
/// run, as the progress lines do.
struct PoorStretch {
  static constexpr std::size_t kWindow = 20;
  static constexpr std::size_t kQuiet = 10;
  std::size_t first = 0;  ///< its first weak match
  std::size_t last = 0;   ///< its last weak match (so far, while open)
  std::size_t weak = 0;   ///< weak matches from first to last
  bool open = true;
};

struct SlamRunStats {
  std::size_t scans = 0;
  std::size_t inserted = 0;
  std::vector<double> ms_per_scan;  ///< wall time of Slam::process per scan
  std::vector<double> search_ms;    ///< of which the pose search
  std::vector<double> update_ms;    ///< of which the map update (scans inserted only)
  /// Scans whose match put fewer than half of the end points that fell on observed cells on
  /// occupied ones (FitnessValue::agreement() < 0.5): the search is likely stuck or lost.
  std::size_t weak_matches = 0;
  std::size_t recoveries_tried = 0;         ///< scans the recovery search ran for
  std::size_t recovered = 0;                ///< ... whose pose it replaced
  std::size_t withheld = 0;                 ///< scans due for insertion kept out of the map
  std::vector<double> agreement;            ///< per scan (after the first)
  std::vector<PoorStretch> poor_stretches;  ///< in order; only the last may be open
  std::vector<std::size_t> recent_weak;     ///< weak matches among the last kWindow scans
  double wall_s = 0.0;                      ///< first scan to the end of the last one
  bool interrupted = false;                 ///< stopped by the stop flag before the source ended

  /// What recording one scan did to the poor stretches.
  enum class Stretch { kNone, kOpened, kClosed };
  /// Adds one processed scan: its step and the wall time of Slam::process.
  Stretch record(const SlamStep& step, double ms);
};

/// Called after each scan: the scan, what the SLAM did with it, scans processed so far.
using StepCallback = std::function<void(const LaserScan&, const SlamStep&, std::size_t)>;

/// Runs the scans of `source` through `slam` in order until the source ends, `max_scans` scans
/// were processed (0 = no limit) or `stop` is set (then interrupted = true, unless the source
/// had ended anyway). wall_s runs from the first scan to the end of the last (without the wait
/// for the first scan and the idle end).
SlamRunStats run_slam(Slam& slam, app::ScanSource& source, std::size_t max_scans,
                      const std::atomic<bool>& stop, const StepCallback& on_step = {});

/// Writes map.pgm, map.yaml, map.png, trajectory.txt, map.digest (tile_codec.hpp) and stats.json
/// into `dir` (created if needed), each atomically. `extra` is merged into stats.json.
void write_slam_outputs(const std::string& dir, const Slam& slam, const SlamRunStats& stats,
                        const nlohmann::json& extra);

}  // namespace esfleet::leader
