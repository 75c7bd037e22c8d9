#pragma once
// Statistics of a SLAM run and writing its results (map files, trajectory, stats.json).

#include <atomic>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet::app {

struct SlamRunStats {
  std::size_t scans = 0;
  std::size_t inserted = 0;
  std::vector<double> ms_per_scan;  ///< wall time of Slam::process per scan
  std::vector<double> search_ms;    ///< of which the pose search
  std::vector<double> update_ms;    ///< of which the map update (scans inserted only)
  /// Scans whose match put fewer than half of the end points that fell on observed cells on
  /// occupied ones (FitnessValue::agreement() < 0.5): the search is likely stuck or lost.
  std::size_t weak_matches = 0;
  std::vector<double> agreement;  ///< per scan (after the first)

  /// Adds one processed scan: its step and the wall time of Slam::process.
  void record(const SlamStep& step, double ms);
  double wall_s = 0.0;
  bool interrupted = false;
};

/// Median, p95, p99, max and mean of a sample (milliseconds in, same out); zeros when empty.
struct Summary {
  double median = 0, p95 = 0, p99 = 0, max = 0, mean = 0;
};
Summary summarize(std::vector<double> values);

/// Writes map.pgm, map.yaml, map.png, trajectory.txt, map.digest (tile_codec.hpp) and stats.json
/// into `dir` (created if needed), each atomically. `extra` is merged into stats.json.
void write_slam_outputs(const std::string& dir, const Slam& slam, const SlamRunStats& stats,
                        const nlohmann::json& extra);

}  // namespace esfleet::app
