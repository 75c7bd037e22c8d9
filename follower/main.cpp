// esfleet-follower: joins a fleet's DDS domain, rebuilds the leader's shared map from its tiles
// (counters bit-identical to the leader's) and, given its own scans (--log or --scan-topic),
// finds its pose in that map with no prior knowledge (global localisation) or around a hint,
// then tracks it and publishes it on the pose topic with its status.

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <unistd.h>
#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "app/dds_flags.hpp"
#include "app/localise_params.hpp"
#include "app/scan_source.hpp"
#include "app/slam_params.hpp"
#include "app/slam_run.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/core/localiser.hpp"
#include "esfleet/core/map_png.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/core/trajectory_io.hpp"
#include "esfleet/dds/map_convert.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/writer.hpp"
#include "map_follower.hpp"

namespace {

std::atomic<bool> g_stop{false};
std::atomic<bool> g_save{false};
extern "C" void on_signal(int) { g_stop.store(true); }
extern "C" void on_save(int) { g_save.store(true); }

std::uint8_t status_of(esfleet::LocaliserState s) {
  using esfleet::LocaliserState;
  switch (s) {
    case LocaliserState::kWaitingForMap:
      return esfleet::msg::kStatusWaitingForMap;
    case LocaliserState::kLocalising:
      return esfleet::msg::kStatusLocalising;
    case LocaliserState::kTracking:
      return esfleet::msg::kStatusTracking;
    case LocaliserState::kLost:
      return esfleet::msg::kStatusLost;
  }
  return esfleet::msg::kStatusLost;
}

/// What the follower's localisation did, for stats.json.
struct LocaliseStats {
  std::size_t scans = 0;
  std::size_t scans_waiting_for_map = 0;
  std::size_t declarations = 0;
  std::size_t lost_events = 0;
  std::size_t global_searches = 0;
  double cpu_s_total = 0.0;
  double cpu_s_to_first_pose = -1.0;  ///< CPU from the first scan with a map to the declaration
  double cpu_s_localising = 0.0;      ///< running sum while not tracking
  std::size_t scans_to_first_pose = 0;
  std::size_t scans_localising = 0;
  std::optional<esfleet::TimedPose> first_pose;
  std::vector<double> tracking_cpu_ms;
  std::uint64_t dropped_tracking = 0;   ///< topic scans skipped (newer one waiting) while tracking
  std::vector<double> tracking_lag_ms;  ///< topic scans: arrival to pose published, tracking
};

}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  using Clock = std::chrono::steady_clock;
  spdlog::set_default_logger(spdlog::stderr_color_st("follower"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App cli{
      "esfleet-follower: receives the leader's shared map over DDS (topics esfleet/map/tiles, "
      "esfleet/map/tile_deltas, esfleet/map/meta) and keeps a copy whose counters equal the "
      "leader's. Given its own scans (--log or --scan-topic) it finds its pose in that map with "
      "the (mu+1)-ES, globally (no hint) or around --hint, then tracks it, relocalises when "
      "lost, and publishes pose and status on esfleet/robots/pose.\n"
      "With --save-map DIR it writes DIR/map.pgm, map.yaml (ROS map_server), map.png, "
      "map.digest (per-tile counter digests) and stats.json at exit, and on SIGUSR1."};
  int domain = 0;
  std::string profile, map_id, save_dir, log_path, scan_robot, hint_text, trajectory_path;
  std::string secure_dir;  // DDS Security (docs/security.md); empty = off
  std::string robot_id = "follower";
  bool exit_when_complete = false, wait_complete = false, latest_only = true;
  double timeout = 0.0, rate = 1.0, idle_exit = 0.0, leader_timeout = 5.0;
  std::size_t max_scans = 0, first_scan = 0;
  app::add_dds_flags(cli, domain, profile, secure_dir);
  cli.add_option("--map-id", map_id, "map to follow (default: the first one seen)");
  cli.add_option("--save-map", save_dir, "directory to save the map into (at exit, SIGUSR1)");
  cli.add_flag("--exit-when-complete", exit_when_complete,
               "without scans: exit (saving) once the leader's map is final and every tile is "
               "here");
  cli.add_option("--timeout", timeout, "stop after this many seconds (0 = no limit)")
      ->capture_default_str();
  cli.add_option("--leader-timeout", leader_timeout,
                 "report the leader gone when no map summary came for S seconds while it was "
                 "mapping (0 = only when DDS reports its writers gone); the map and tracking "
                 "are kept either way")
      ->capture_default_str();
  auto* log_opt = cli.add_option("--log", log_path,
                                 "this robot's scans from a CARMEN log (localise in the map)");
  cli.add_option("--scan-topic", scan_robot,
                 "this robot's scans from the DDS scan topic, published under this robot id")
      ->excludes(log_opt);
  cli.add_option("--rate", rate,
                 "--log: replay speed (1 = recorded speed, 0 = as fast as possible)")
      ->capture_default_str();
  cli.add_option("--max-scans", max_scans, "--log: read the first N scans (0 = all)")
      ->capture_default_str();
  cli.add_option("--first-scan", first_scan,
                 "--log: start at this scan (skip the ones before; counted from 0)")
      ->capture_default_str();
  cli.add_option("--idle-exit", idle_exit,
                 "--scan-topic: end once no scan arrived for this many seconds (0 = never)")
      ->capture_default_str();
  cli.add_option("--latest-only", latest_only,
                 "--scan-topic: when scans are waiting, process the newest and skip the older "
                 "ones (real time: no backlog after a global search); false = every scan in order")
      ->capture_default_str();
  cli.add_option("--robot-id", robot_id, "this robot's id on the pose topic")
      ->capture_default_str();
  cli.add_option("--hint", hint_text,
                 "start pose guess x,y,theta_deg[,radius_m[,angle_deg]] (default radius 1 m, "
                 "angle 30 deg); without it the search is global");
  cli.add_flag("--wait-complete", wait_complete,
               "hold the scans until the leader's map is complete (tests, benchmarks)");
  cli.add_option("--trajectory", trajectory_path,
                 "write the tracked poses (stamp x y theta per line) to this file at exit");
  app::ParamTable params;
  // The SLAM flags, as the leader takes them: tracking uses slam.tracking and slam.seed.
  SlamConfig slam;
  LocaliserConfig lconfig;
  CarmenReaderOptions reader_options;
  app::add_slam_params(params, &slam, &reader_options);
  app::add_localise_params(params, &lconfig);
  params.bind(cli, "Localisation parameters (tracking uses the SLAM's)");
  CLI11_PARSE(cli, argc, argv);
  try {
    params.apply();
    if (!hint_text.empty()) lconfig.hint = app::parse_hint(hint_text);
    lconfig.tracking = slam.tracking;
    lconfig.seed = slam.seed;
    slam.validate();
    lconfig.validate();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  if (timeout < 0.0 || rate < 0.0 || idle_exit < 0.0 || leader_timeout < 0.0) {
    spdlog::error("--timeout, --rate, --idle-exit and --leader-timeout must be >= 0");
    return 2;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGUSR1, on_save);

  std::unique_ptr<dds::Node> node;
  std::unique_ptr<follower::MapFollower> follow;
  std::unique_ptr<app::ScanSource> source;
  std::unique_ptr<dds::PoseWriter> pose_writer;
  app::TopicScanSource* topic = nullptr;
  try {
    if (!log_path.empty()) {
      std::vector<LaserScan> scans =
          app::read_log(log_path, reader_options, max_scans, lconfig.tracking.use_odometry, g_stop);
      if (first_scan >= scans.size()) {
        throw std::invalid_argument("--first-scan " + std::to_string(first_scan) + ": " + log_path +
                                    " has only " + std::to_string(scans.size()) + " scans" +
                                    (max_scans > 0 ? " (with --max-scans)" : ""));
      }
      scans.erase(scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(first_scan));
      source = std::make_unique<app::LogScanSource>(std::move(scans), rate);
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  try {
    node = std::make_unique<dds::Node>(
        dds::NodeOptions{domain, profile, "esfleet-follower", secure_dir});
    GridMapConfig local;
    local.pyramid_levels = std::max(lconfig.search.coarse_level, lconfig.search.mid_level);
    follow = std::make_unique<follower::MapFollower>(*node, map_id, local);
    if (!scan_robot.empty()) {
      auto t = std::make_unique<app::TopicScanSource>(*node, scan_robot, idle_exit, latest_only);
      topic = t.get();
      source = std::move(t);
    }
    if (source) pose_writer = std::make_unique<dds::PoseWriter>(*node, robot_id);
  } catch (const std::exception& e) {
    spdlog::error("DDS: {}", e.what());
    return 2;
  }
  spdlog::info("following map '{}' on DDS domain {}", map_id.empty() ? "(any)" : map_id, domain);
  if (source) {
    spdlog::info("robot '{}': scans from {}; {} localisation", robot_id,
                 log_path.empty() ? "scan topic of '" + scan_robot + "'" : log_path,
                 lconfig.hint ? "hinted" : "global");
  }

  const auto start = Clock::now();
  const auto seconds_since_start = [&] {
    return std::chrono::duration<double>(Clock::now() - start).count();
  };
  double first_tile_s = -1.0, complete_s = -1.0;
  // Nothing from any leader after this long: say what is likely wrong, once.
  constexpr double kNoMapWarnS = 10.0;
  bool warned_no_map = false;
  auto warn_no_map = [&] {
    const int matched = follow->matched_leaders();
    if (matched == 0) {
      spdlog::warn(
          "no leader found in {:.0f} s on DDS domain {}{}: is a leader running with the same "
          "domain id, a compatible --profile{} and a network path to this robot? (Over shared "
          "memory, a process killed earlier on this host can also cause this: docs/faults.md, "
          "'Shared memory and killed processes'.)",
          kNoMapWarnS, domain, profile.empty() ? "" : " with profile " + profile,
          secure_dir.empty() ? "" : " and certificates of the same CA");
    } else {
      spdlog::warn(
          "matched {} leader map writer(s) but received nothing from them in {:.0f} s: "
          "either the leader has not mapped a scan yet (is its scan source running?) or, over "
          "shared memory (localhost-shm.xml), a process killed earlier on this host left it "
          "writing to ports that no longer exist (Fast DDS 2.9; docs/faults.md, 'Shared memory "
          "and killed processes'): restart the leader, or run every program with "
          "deploy/fastdds/localhost-udp.xml",
          matched, kNoMapWarnS);
    }
  };
  auto last_report = start;
  bool timed_out = false, scans_ended = false;
  Localiser localiser(lconfig);
  LocaliseStats ls;
  std::vector<TimedPose> trajectory;
  LocaliserStep last_step;
  std::optional<std::uint32_t> epoch;

  // The leader's presence. Present from its first map summary; gone when DDS unmatches its tile
  // writer (participant lease expired or it left) or, while it maps, when no summary came for
  // --leader-timeout s; back at the next summary. A lost leader changes nothing else: the map
  // stays, tracking goes on, a resumed or new leader's tiles are applied as they come.
  struct LeaderWatch {
    bool present = false;
    bool matched_seen = false;  ///< its tile writer was matched during this presence
    std::uint64_t meta_seen = 0;
    Clock::time_point last_meta;
    Clock::time_point last_check;
    std::uint64_t lost = 0, returned = 0;
    double lost_at_s = -1.0;        ///< last loss: when noticed (s since start)
    double silence_at_loss = -1.0;  ///< ... seconds after the last summary
    double returned_at_s = -1.0;
    std::string reason;
  } leader;
  auto watch_leader = [&] {
    const auto now = Clock::now();
    const auto& s = follow->stats();
    if (s.meta_received != leader.meta_seen) {
      leader.meta_seen = s.meta_received;
      leader.last_meta = now;
      if (!leader.present) {
        leader.present = true;
        leader.matched_seen = false;
        if (leader.lost > 0) {
          ++leader.returned;
          leader.returned_at_s = seconds_since_start();
          spdlog::info("leader back ({:.1f} s after it was reported gone)",
                       leader.returned_at_s - leader.lost_at_s);
        }
      }
    }
    if (!leader.present || now - leader.last_check < std::chrono::milliseconds(100)) return;
    leader.last_check = now;
    const int matched = follow->matched_leaders();
    if (matched > 0) leader.matched_seen = true;
    const double silent = std::chrono::duration<double>(now - leader.last_meta).count();
    const auto& meta = follow->replica().meta();
    const bool mapping = meta && !meta->complete();
    std::string why;
    if (leader.matched_seen && matched == 0) {
      why = "DDS reports its map writer gone";
    } else if (leader_timeout > 0 && mapping && silent > leader_timeout) {
      why = fmt::format("no map summary for {:.1f} s while it was mapping", silent);
    }
    if (why.empty()) return;
    leader.present = false;
    ++leader.lost;
    leader.lost_at_s = seconds_since_start();
    leader.silence_at_loss = silent;
    leader.reason = why;
    spdlog::warn(
        "leader gone: {} (last summary {:.1f} s ago, at its scan {}); keeping the map ({} tiles) "
        "and {}",
        why, silent, meta ? meta->scans() : 0,
        follow->replica().has_map() ? follow->replica().map().tile_count() : 0,
        source ? "tracking" : "waiting");
  };
  auto leader_json = [&]() -> nlohmann::json {
    return {{"present", leader.present},
            {"lost_at_s", leader.lost_at_s},
            {"silence_at_loss_s", leader.silence_at_loss},
            {"returned_at_s", leader.returned_at_s},
            {"reason", leader.reason},
            {"leader_timeout_s", leader_timeout}};
  };

  auto localise_json = [&]() -> nlohmann::json {
    const app::Summary tr = app::summarize(ls.tracking_cpu_ms);
    const app::Summary lag = app::summarize(ls.tracking_lag_ms);
    nlohmann::json j = {{"robot_id", robot_id},
                        {"state", to_string(localiser.state())},
                        {"scans", ls.scans},
                        {"scans_waiting_for_map", ls.scans_waiting_for_map},
                        {"declarations", ls.declarations},
                        {"lost_events", ls.lost_events},
                        {"global_searches", ls.global_searches},
                        {"cpu_s_total", ls.cpu_s_total},
                        {"cpu_s_to_first_pose", ls.cpu_s_to_first_pose},
                        {"scans_to_first_pose", ls.scans_to_first_pose},
                        {"tracked_scans", trajectory.size()},
                        {"tracking_cpu_ms_median", tr.median},
                        {"tracking_cpu_ms_p95", tr.p95}};
    if (topic != nullptr) {
      j["scans_dropped"] = topic->stats().dropped;
      j["scans_dropped_tracking"] = ls.dropped_tracking;
      j["tracking_lag_ms_median"] = lag.median;
      j["tracking_lag_ms_p95"] = lag.p95;
      j["tracking_lag_ms_max"] = lag.max;
    }
    if (ls.first_pose) {
      j["first_pose"] = {{"stamp", ls.first_pose->stamp},
                         {"x", ls.first_pose->pose.x},
                         {"y", ls.first_pose->pose.y},
                         {"theta", ls.first_pose->pose.theta}};
    }
    return j;
  };

  auto save = [&](const char* why) {
    bool ok = true;
    if (!trajectory_path.empty()) {
      try {
        const std::filesystem::path parent = std::filesystem::path(trajectory_path).parent_path();
        if (!parent.empty()) std::filesystem::create_directories(parent);
        write_trajectory(trajectory_path, trajectory);
      } catch (const std::exception& e) {
        spdlog::error("writing the trajectory {}: {}", trajectory_path, e.what());
        ok = false;
      }
    }
    if (save_dir.empty()) return ok;
    if (!follow->replica().has_map()) {
      spdlog::warn("no map received yet: nothing to save in {}", save_dir);
      return false;
    }
    try {
      const GridMap& map = follow->replica().map();
      save_ros_map(map, save_dir, "map");
      save_map_png(map, trajectory, save_dir + "/map.png");
      write_file_atomically(save_dir + "/map.digest", map_digest(map));
      const auto& s = follow->stats();
      const app::Summary lat = app::summarize(s.latency_ms);
      nlohmann::json j = {
          {"map_id", follow->replica().map_id()},
          {"epoch", follow->replica().epoch()},
          {"complete", follow->replica().complete()},
          {"tiles", map.tile_count()},
          {"tiles_received", s.tiles_received},
          {"tiles_applied", s.tiles_applied},
          {"tiles_stale", s.tiles_stale},
          {"tiles_ignored", s.tiles_ignored},
          {"tiles_rejected", s.tiles_rejected},
          {"deltas_received", s.deltas_received},
          {"deltas_applied", s.deltas_applied},
          {"deltas_stale", s.deltas_stale},
          {"deltas_needs_base", s.deltas_needs_base},
          {"deltas_ignored", s.deltas_ignored},
          {"deltas_rejected", s.deltas_rejected},
          {"meta_received", s.meta_received},
          {"meta_rejected", s.meta_rejected},
          {"bytes_received", s.bytes_received},
          {"latency_ms_median", lat.median},
          {"latency_ms_p99", lat.p99},
          {"latency_ms_max", lat.max},
          {"first_tile_s", first_tile_s},
          {"time_to_complete_s", complete_s},
          {"saved_because", why},
          {"leader_lost", leader.lost},
          {"leader_returned", leader.returned},
          {"leader", leader_json()},
      };
      if (source) j["localisation"] = localise_json();
      write_file_atomically(save_dir + "/stats.json", j.dump(2) + "\n");
      spdlog::info("saved the map ({} tiles) to {}", map.tile_count(), save_dir);
      return ok;
    } catch (const std::exception& e) {
      spdlog::error("saving the map to {}: {}", save_dir, e.what());
      return false;
    }
  };

  auto process_scan = [&](const LaserScan& scan) {
    ++ls.scans;
    const dds::MapReplica& replica = follow->replica();
    if (replica.has_map() && epoch && replica.epoch() != *epoch) {
      spdlog::warn("the leader's map changed (epoch {} -> {}): localising afresh", *epoch,
                   replica.epoch());
      localiser.reset();
    }
    if (replica.has_map()) epoch = replica.epoch();
    static const GridMap kEmpty;
    const LocaliserStep step = localiser.process(replica.has_map() ? replica.map() : kEmpty, scan);
    last_step = step;
    ls.cpu_s_total += step.cpu_ms * 1e-3;
    if (step.global_search) ++ls.global_searches;
    if (step.state == LocaliserState::kWaitingForMap) {
      ++ls.scans_waiting_for_map;
    } else if (step.state != LocaliserState::kTracking || step.declared) {
      ls.cpu_s_localising += step.cpu_ms * 1e-3;
      ++ls.scans_localising;
    }
    if (step.declared) {
      ++ls.declarations;
      if (!ls.first_pose) {
        ls.first_pose = TimedPose{scan.stamp, step.pose};
        ls.cpu_s_to_first_pose = ls.cpu_s_localising;
        ls.scans_to_first_pose = ls.scans_localising;
      }
      spdlog::info(
          "localised at ({:.2f}, {:.2f}, {:.1f} deg) after {} scans, {:.2f} s CPU "
          "(evidence {:.2f}, agreement {:.2f})",
          step.pose.x, step.pose.y, rad_to_deg(step.pose.theta), ls.scans_localising,
          ls.cpu_s_localising, step.score, step.value.agreement());
      ls.cpu_s_localising = 0.0;
      ls.scans_localising = 0;
    }
    if (step.lost) {
      ++ls.lost_events;
      spdlog::warn("lost: the scans stopped matching the map; relocalising");
    }
    if (step.state == LocaliserState::kTracking) {
      trajectory.push_back({scan.stamp, step.pose});
      if (!step.declared) ls.tracking_cpu_ms.push_back(step.cpu_ms);
    }
    if (pose_writer) {
      pose_writer->write(dds::pose_to_msg(robot_id, {scan.stamp, step.pose}, step.value.fitness,
                                          status_of(step.state)));
    }
  };

  while (!g_stop.load()) {
    follow->spin_once(std::chrono::milliseconds(source ? 2 : 50));
    watch_leader();
    if (first_tile_s < 0 && follow->stats().tiles_applied > 0) first_tile_s = seconds_since_start();
    if (!warned_no_map && follow->stats().tiles_received == 0 &&
        follow->stats().meta_received == 0 && seconds_since_start() > kNoMapWarnS) {
      warned_no_map = true;
      warn_no_map();
    }
    if (complete_s < 0 && follow->replica().complete()) {
      complete_s = seconds_since_start();
      spdlog::info("map complete: {} tiles after {:.2f} s", follow->replica().map().tile_count(),
                   complete_s);
      if (exit_when_complete && !source) break;
    }
    if (source && (!wait_complete || complete_s >= 0)) {
      // One scan at a time, then DDS again: tiles keep arriving while the robot localises.
      if (source->ready()) {
        const std::uint64_t dropped_before = topic != nullptr ? topic->stats().dropped : 0;
        const bool was_tracking = localiser.state() == LocaliserState::kTracking;
        if (auto scan = source->next(g_stop)) {
          process_scan(*scan);
          if (topic != nullptr && was_tracking) {
            ls.dropped_tracking += topic->stats().dropped - dropped_before;
            ls.tracking_lag_ms.push_back(std::chrono::duration<double, std::milli>(
                                             Clock::now() - topic->last_arrival_of_returned())
                                             .count());
          }
        } else if (source->ended()) {
          scans_ended = true;
          spdlog::info("scans ended after {} scans: state {}", ls.scans,
                       to_string(localiser.state()));
          break;
        }
      } else {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    }
    if (g_save.exchange(false)) save("SIGUSR1");
    if (Clock::now() - last_report > std::chrono::seconds(5)) {
      last_report = Clock::now();
      const auto& s = follow->stats();
      spdlog::info(
          "tiles: {} applied, {} stale, {} rejected; deltas: {} applied, {} waiting for a "
          "whole tile; map {} tiles; leaders matched {}",
          s.tiles_applied, s.tiles_stale, s.tiles_rejected, s.deltas_applied, s.deltas_needs_base,
          follow->replica().has_map() ? follow->replica().map().tile_count() : 0,
          follow->matched_leaders());
      if (source) {
        spdlog::info("robot '{}': {} at ({:.2f}, {:.2f}, {:.1f} deg), {} scans, {} hypotheses",
                     robot_id, to_string(last_step.state), last_step.pose.x, last_step.pose.y,
                     rad_to_deg(last_step.pose.theta), ls.scans, last_step.hypotheses);
      }
    }
    if (timeout > 0 && seconds_since_start() > timeout) {
      timed_out = true;
      spdlog::warn("--timeout {} s reached", timeout);
      break;
    }
  }
  if (topic != nullptr) {
    const app::TopicScanStats t = topic->stats();
    spdlog::info(
        "scan topic: {} received, {} malformed, {} missing (seq gaps), {} skipped for newer "
        "ones ({} while tracking)",
        t.received, t.malformed, t.seq_gaps, t.dropped, ls.dropped_tracking);
  }
  if (pose_writer) pose_writer->wait_for_acknowledgments(std::chrono::milliseconds(500));
  const bool saved = save(g_stop.load() ? "signal"
                          : timed_out   ? "timeout"
                          : scans_ended ? "scans ended"
                                        : "complete");
  if (!saved && (!save_dir.empty() || !trajectory_path.empty())) return 1;
  return timed_out ? 3 : 0;
}
