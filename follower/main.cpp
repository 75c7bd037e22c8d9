// esfleet-follower: joins a fleet's DDS domain, rebuilds the leader's shared map from its tiles
// (counters bit-identical to the leader's) and saves it. Localisation in the shared map comes
// in a later step.

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <csignal>
#include <nlohmann/json.hpp>

#include "app/slam_run.hpp"
#include "esfleet/core/map_io.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/dds/node.hpp"
#include "map_follower.hpp"

namespace {

std::atomic<bool> g_stop{false};
std::atomic<bool> g_save{false};
extern "C" void on_signal(int) { g_stop.store(true); }
extern "C" void on_save(int) { g_save.store(true); }

}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  using Clock = std::chrono::steady_clock;
  spdlog::set_default_logger(spdlog::stderr_color_st("follower"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App cli{
      "esfleet-follower: receives the leader's shared map over DDS (topics esfleet/map/tiles, "
      "esfleet/map/meta) and keeps a copy whose counters equal the leader's.\n"
      "With --save-map DIR it writes DIR/map.pgm, map.yaml (ROS map_server), map.png, "
      "map.digest (per-tile counter digests) and stats.json at exit, and on SIGUSR1."};
  int domain = 0;
  std::string profile, map_id, save_dir;
  bool exit_when_complete = false;
  double timeout = 0.0;
  cli.add_option("--domain", domain, "DDS domain id (0-232)")->capture_default_str();
  cli.add_option("--profile", profile,
                 "Fast DDS XML profile (deploy/fastdds/*.xml); default: Fast DDS defaults");
  cli.add_option("--map-id", map_id, "map to follow (default: the first one seen)");
  cli.add_option("--save-map", save_dir, "directory to save the map into (at exit, SIGUSR1)");
  cli.add_flag("--exit-when-complete", exit_when_complete,
               "exit (saving) once the leader's map is final and every tile is here");
  cli.add_option("--timeout", timeout, "stop after this many seconds (0 = no limit)")
      ->capture_default_str();
  CLI11_PARSE(cli, argc, argv);
  if (timeout < 0.0) {
    spdlog::error("--timeout must be >= 0");
    return 2;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGUSR1, on_save);

  std::unique_ptr<dds::Node> node;
  std::unique_ptr<follower::MapFollower> follow;
  try {
    node = std::make_unique<dds::Node>(dds::NodeOptions{domain, profile, "esfleet-follower"});
    follow = std::make_unique<follower::MapFollower>(*node, map_id);
  } catch (const std::exception& e) {
    spdlog::error("DDS: {}", e.what());
    return 2;
  }
  spdlog::info("following map '{}' on DDS domain {}", map_id.empty() ? "(any)" : map_id, domain);

  const auto start = Clock::now();
  const auto seconds_since_start = [&] {
    return std::chrono::duration<double>(Clock::now() - start).count();
  };
  double first_tile_s = -1.0, complete_s = -1.0;
  auto last_report = start;
  bool timed_out = false;

  auto save = [&](const char* why) {
    if (save_dir.empty()) return true;
    if (!follow->replica().has_map()) {
      spdlog::warn("no map received yet: nothing to save in {}", save_dir);
      return false;
    }
    try {
      const GridMap& map = follow->replica().map();
      save_ros_map(map, save_dir, "map");
      save_map_png(map, {}, save_dir + "/map.png");
      write_file_atomically(save_dir + "/map.digest", map_digest(map));
      const auto& s = follow->stats();
      const app::Summary lat = app::summarize(s.latency_ms);
      const nlohmann::json j = {
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
      };
      write_file_atomically(save_dir + "/stats.json", j.dump(2) + "\n");
      spdlog::info("saved the map ({} tiles) to {}", map.tile_count(), save_dir);
      return true;
    } catch (const std::exception& e) {
      spdlog::error("saving the map to {}: {}", save_dir, e.what());
      return false;
    }
  };

  while (!g_stop.load()) {
    follow->spin_once(std::chrono::milliseconds(50));
    if (first_tile_s < 0 && follow->stats().tiles_applied > 0) first_tile_s = seconds_since_start();
    if (complete_s < 0 && follow->replica().complete()) {
      complete_s = seconds_since_start();
      spdlog::info("map complete: {} tiles after {:.2f} s", follow->replica().map().tile_count(),
                   complete_s);
      if (exit_when_complete) break;
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
    }
    if (timeout > 0 && seconds_since_start() > timeout) {
      timed_out = true;
      spdlog::warn("--timeout {} s reached", timeout);
      break;
    }
  }
  const bool saved = save(g_stop.load() ? "signal" : timed_out ? "timeout" : "complete");
  if (!saved && !save_dir.empty()) return 1;
  return timed_out ? 3 : 0;
}
