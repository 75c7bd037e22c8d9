#include "slam_run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include <spdlog/spdlog.h>

#include "app/summary.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/core/map_png.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/core/trajectory_io.hpp"

namespace esfleet::leader {

SlamRunStats::Stretch SlamRunStats::record(const SlamStep& step, double ms) {
  ms_per_scan.push_back(ms);
  ++scans;
  inserted += step.inserted ? 1 : 0;
  recoveries_tried += step.recovery_tried ? 1 : 0;
  recovered += step.recovered ? 1 : 0;
  withheld += step.withheld ? 1 : 0;
  search_ms.push_back(step.search_ms);
  if (step.inserted) update_ms.push_back(step.update_ms);
  bool weak = false;
  if (scans > 1) {
    const float a = step.fitness.agreement();
    agreement.push_back(a);
    weak = a < 0.5f;
    if (weak) ++weak_matches;
  }
  std::erase_if(recent_weak, [this](std::size_t s) { return s + PoorStretch::kWindow <= scans; });
  if (weak) recent_weak.push_back(scans);
  PoorStretch* open =
      !poor_stretches.empty() && poor_stretches.back().open ? &poor_stretches.back() : nullptr;
  if (open != nullptr) {
    if (weak) {
      open->last = scans;
      ++open->weak;
    } else if (scans - open->last >= PoorStretch::kQuiet) {
      open->open = false;
      return Stretch::kClosed;
    }
    return Stretch::kNone;
  }
  if (recent_weak.size() * 2 < PoorStretch::kWindow) return Stretch::kNone;
  poor_stretches.push_back({recent_weak.front(), recent_weak.back(), recent_weak.size(), true});
  return Stretch::kOpened;
}

SlamRunStats run_slam(Slam& slam, app::ScanSource& source, std::size_t max_scans,
                      const std::atomic<bool>& stop, const StepCallback& on_step) {
  using Clock = std::chrono::steady_clock;
  SlamRunStats stats;
  stats.ms_per_scan.reserve(source.total());
  // Wall time from the first scan to the last one processed: not the wait for the first scan
  // on the topic, nor the idle time before the end.
  std::optional<Clock::time_point> first;
  Clock::time_point last;
  // The short laser's hold (SlamConfig::short_view_range): said when it starts and when a
  // longer beam ends it.
  bool holding = false;
  while (max_scans == 0 || stats.scans < max_scans) {
    const std::optional<LaserScan> scan = source.next(stop);
    if (!scan) {
      stats.interrupted = !source.ended();
      break;
    }
    const auto t0 = Clock::now();
    if (!first) first = t0;
    const SlamStep step = slam.process(*scan);
    const auto t1 = Clock::now();
    const SlamRunStats::Stretch stretch =
        stats.record(step, std::chrono::duration<double, std::milli>(t1 - t0).count());
    if (stretch == SlamRunStats::Stretch::kOpened) {
      const PoorStretch& p = stats.poor_stretches.back();
      spdlog::warn(
          "scans {}-{}: {} of the last {} matched the map poorly (under half of the end points "
          "on mapped cells on occupied ones): the SLAM may have lost track, and the map from "
          "scan {} on may be wrong",
          p.first, stats.scans, p.weak, PoorStretch::kWindow, p.first);
    } else if (stretch == SlamRunStats::Stretch::kClosed) {
      const PoorStretch& p = stats.poor_stretches.back();
      spdlog::info("scans match the map again: {} poor matches in scans {}-{}", p.weak, p.first,
                   p.last);
    }
    if (slam.short_view_hold() != holding) {
      holding = !holding;
      if (holding) {
        spdlog::info(
            "scan {}: no beam of {:g} m or more so far (a short laser): with odometry the "
            "tracking holds along the motion where the map cannot tell how far the robot went "
            "(--short-view-range, --short-view-motion-hold)",
            stats.scans, slam.config().short_view_range);
      } else {
        spdlog::info("scan {}: a beam of {:.1f} m: the short laser's hold ends", stats.scans,
                     slam.laser_reach());
      }
    }
    if (on_step) on_step(*scan, step, stats.scans);
    last = Clock::now();
  }
  // A loop-closure search still speculative is applied: what follows (outputs, checkpoint,
  // the final pass) sees the state the mapping thread would have reached on its own.
  slam.settle();
  if (first) stats.wall_s = std::chrono::duration<double>(last - *first).count();
  return stats;
}

void write_slam_outputs(const std::string& dir, const Slam& slam, const SlamRunStats& stats,
                        const nlohmann::json& extra) {
  std::filesystem::create_directories(dir);
  save_ros_map(slam.map(), dir, "map");
  save_map_png(slam.map(), slam.trajectory(), dir + "/map.png");
  write_trajectory(dir + "/trajectory.txt", slam.trajectory());
  write_file_atomically(dir + "/map.digest", map_digest(slam.map()));

  const app::Summary ms = app::summarize(stats.ms_per_scan);
  const GridMap::Bounds b = slam.map().known_bounds();
  const double cs = slam.map().cell_size();
  nlohmann::json j = extra;
  j["scans"] = stats.scans;
  j["inserted_scans"] = stats.inserted;
  j["interrupted"] = stats.interrupted;
  j["wall_s"] = stats.wall_s;
  j["ms_per_scan_median"] = ms.median;
  j["ms_per_scan_p95"] = ms.p95;
  j["ms_per_scan_max"] = ms.max;
  j["ms_per_scan_mean"] = ms.mean;
  j["search_ms_median"] = app::summarize(stats.search_ms).median;
  j["search_ms_p95"] = app::summarize(stats.search_ms).p95;
  j["update_ms_median"] = app::summarize(stats.update_ms).median;
  j["agreement_median"] = app::summarize(stats.agreement).median;
  j["weak_matches"] = stats.weak_matches;
  j["recoveries_tried"] = stats.recoveries_tried;
  j["recovered"] = stats.recovered;
  j["withheld_scans"] = stats.withheld;
  nlohmann::json poor = nlohmann::json::array();
  for (const PoorStretch& p : stats.poor_stretches) {
    poor.push_back({{"first", p.first}, {"last", p.last}, {"weak", p.weak}});
  }
  j["poor_stretches"] = poor;
  j["loop_closures"] = slam.loop_closures();
  j["loop_closures_rejected"] = slam.loop_closures_rejected();
  j["key_scans"] = slam.key_scans();
  // The longest beam of the key scans, and whether the short laser's hold was on at the end.
  j["laser_reach_m"] = slam.laser_reach();
  j["short_view_hold"] = slam.short_view_hold();
  j["map"] = {
      {"tiles", slam.map().tile_count()},
      {"tile_edge", slam.map().tile_edge()},
      {"cell_size", cs},
      {"width_m", b.empty ? 0.0 : (b.max.x - b.min.x + 1) * cs},
      {"height_m", b.empty ? 0.0 : (b.max.y - b.min.y + 1) * cs},
  };
  // Last, so that it covers writing the maps.
  j["peak_rss_mb"] = app::peak_rss_mb();
  write_file_atomically(dir + "/stats.json", j.dump(2) + "\n");
}

}  // namespace esfleet::leader
