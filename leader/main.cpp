// esfleet-leader: maps with the (mu+1)-ES SLAM and shares the map over DDS. With --offline it
// only runs a recorded log through the SLAM and writes the map, trajectory and statistics;
// otherwise it also publishes the changed map tiles, the map summary and its pose while it maps,
// and keeps serving the map after the log has ended.

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <nlohmann/json.hpp>
#include <thread>

#include "app/param_table.hpp"
#include "app/slam_params.hpp"
#include "app/slam_run.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/slam.hpp"
#include "esfleet/dds/node.hpp"
#include "map_publisher.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

struct OnlineOptions {
  int domain = 0;
  std::string profile;
  std::string map_id = "map";
  std::uint32_t epoch = 0;  ///< 0 = the start time in seconds, so a restart makes a new epoch
  std::string robot_id = "leader";
  double rate = 0.0;            ///< 0 = as fast as possible, 1 = recorded speed
  double publish_period = 1.0;  ///< seconds of log time between publishes
  double linger = -1.0;         ///< seconds to keep serving after the log; < 0 = until stopped
  std::string encoding = "med";
};

}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  using Clock = std::chrono::steady_clock;
  spdlog::set_default_logger(spdlog::stderr_color_st("leader"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App cli{
      "esfleet-leader: 2D laser SLAM with the (mu+1)-Evolution Strategy of Toda & Kubota, "
      "sharing its map over DDS.\n"
      "Maps a CARMEN log and publishes changed map tiles, the map summary and its pose (topics "
      "esfleet/map/tiles, esfleet/map/meta, esfleet/robots/pose); late joiners get the whole "
      "map. With --offline it runs without DDS. Both write DIR/map.pgm, map.yaml (ROS "
      "map_server), map.png (map with trajectory), trajectory.txt (t x y theta per scan), "
      "map.digest (per-tile counter digests) and stats.json."};
  std::string log_path, out_dir = "out";
  bool offline = false;
  std::size_t max_scans = 0;
  bool paper = false;
  OnlineOptions o;
  cli.add_option("--log", log_path, "CARMEN log (.log/.clf, plain or .gz)")->required();
  cli.add_option("--out", out_dir, "output directory")->capture_default_str();
  cli.add_flag("--offline", offline, "run the log through the SLAM without DDS");
  cli.add_option("--max-scans", max_scans, "stop after N scans (0 = all)")->capture_default_str();
  cli.add_flag("--paper", paper,
               "start from the paper's exact configuration (previous-pose prediction, no "
               "extensions) before applying --config and the flags below");
  auto* dds = cli.add_option_group("DDS", "Map sharing (without --offline)");
  dds->add_option("--domain", o.domain, "DDS domain id (0-232)")->capture_default_str();
  dds->add_option("--profile", o.profile,
                  "Fast DDS XML profile (deploy/fastdds/*.xml); default: Fast DDS defaults");
  dds->add_option("--map-id", o.map_id, "name of the shared map")->capture_default_str();
  dds->add_option("--epoch", o.epoch, "map epoch (0 = start time in seconds: a new map)")
      ->capture_default_str();
  dds->add_option("--robot-id", o.robot_id, "id on the pose topic")->capture_default_str();
  dds->add_option("--rate", o.rate,
                  "replay speed: 0 = as fast as possible, 1 = recorded speed, 2 = twice, ...")
      ->capture_default_str();
  dds->add_option("--publish-period", o.publish_period,
                  "seconds of log time between tile publishes (at --rate 1: wall seconds)")
      ->capture_default_str();
  dds->add_option("--linger", o.linger,
                  "after the log: keep serving the map this many seconds (< 0: until Ctrl-C)")
      ->capture_default_str();
  dds->add_option("--encoding", o.encoding,
                  "tile payload encoding: med = predicted residuals + zlib (smallest), varint = "
                  "varints + zlib, raw = 8 bytes per cell")
      ->check(CLI::IsMember({"med", "varint", "raw"}))
      ->capture_default_str();

  SlamConfig config;
  CarmenReaderOptions reader_options;
  app::ParamTable params;
  app::add_slam_params(params, &config, &reader_options);
  params.bind(cli, "SLAM parameters");
  CLI11_PARSE(cli, argc, argv);

  try {
    if (paper) config = SlamConfig::paper();
    params.apply();
    config.validate();
    if (!(o.rate >= 0.0)) throw std::invalid_argument("--rate must be >= 0");
    if (!(o.publish_period > 0.0)) throw std::invalid_argument("--publish-period must be > 0");
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  std::vector<LaserScan> scans;
  try {
    CarmenReader reader(log_path, reader_options);
    while (auto scan = reader.next_scan()) {
      scans.push_back(std::move(*scan));
      if (max_scans > 0 && scans.size() >= max_scans) break;
      if (g_stop.load()) break;
    }
    if (reader.saw_corrected_poses() && config.use_odometry) {
      spdlog::warn(
          "{} is a GMapping-corrected log: its odometry fields are corrected poses, so "
          "--odometry on makes the result meaningless. Run it laser-only.",
          log_path);
    }
    if (scans.empty()) throw LogError(log_path, 0, "no laser scans (FLASER/ROBOTLASER1) in file");
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  spdlog::info("{}: {} scans", log_path, scans.size());
  for (const auto& [name, value] : params.values()) spdlog::info("  {} = {}", name, value);
  nlohmann::json params_json;
  for (const auto& [name, value] : params.values()) params_json[name] = value;

  std::unique_ptr<dds::Node> node;
  std::unique_ptr<leader::MapPublisher> publisher;
  if (!offline) {
    if (o.epoch == 0) {
      o.epoch = static_cast<std::uint32_t>(dds::realtime_ns() / 1'000'000'000);
    }
    try {
      node = std::make_unique<dds::Node>(dds::NodeOptions{o.domain, o.profile, "esfleet-leader"});
      publisher = std::make_unique<leader::MapPublisher>(
          *node, dds::MapIdentity{o.map_id, o.epoch}, o.robot_id,
          o.encoding == "raw"      ? TileEncoding::kRaw
          : o.encoding == "varint" ? TileEncoding::kVarintZlib
                                   : TileEncoding::kMedZlib);
    } catch (const std::exception& e) {
      spdlog::error("DDS: {}", e.what());
      return 2;
    }
    spdlog::info("sharing map '{}' epoch {} on DDS domain {}{}", o.map_id, o.epoch, o.domain,
                 o.profile.empty() ? "" : " with profile " + o.profile);
  }

  Slam slam(config);
  const std::size_t every = std::max<std::size_t>(1, scans.size() / 20);
  const double t0_log = scans.front().stamp;
  const auto t0_wall = Clock::now();
  double last_publish = -1e300;
  const std::string params_dump = params_json.dump();
  auto publish = [&](bool complete, float fitness) {
    publisher->publish(slam.map(), slam.trajectory().back(), fitness, complete,
                       static_cast<std::uint32_t>(slam.scans_processed()), params_dump);
  };
  const auto stats = app::run_slam(
      slam, scans, &g_stop, [&](std::size_t done, std::size_t total, const SlamStep& step) {
        const LaserScan& scan = scans[done - 1];
        if (publisher && scan.stamp - last_publish >= o.publish_period) {
          publish(false, step.fitness.fitness);
          last_publish = scan.stamp;
        }
        if (done % every == 0 || done == total) {
          spdlog::info("scan {}/{}  pose ({:.2f}, {:.2f}, {:.1f} deg)  fitness {:.1f}  tiles {}",
                       done, total, step.pose.x, step.pose.y, rad_to_deg(step.pose.theta),
                       step.fitness.fitness, slam.map().tile_count());
        }
        if (o.rate > 0.0 && done < total) {
          // Recorded speed: the next scan is due at its log time (scaled) after the start.
          const double due = (scans[done].stamp - t0_log) / o.rate;
          std::this_thread::sleep_until(t0_wall + std::chrono::duration<double>(due));
        }
      });
  if (stats.interrupted) {
    spdlog::warn("interrupted after {} scans: saving what we have", stats.scans);
  }

  nlohmann::json extra;
  extra["log"] = log_path;
  extra["paper_mode"] = paper;
  extra["parameters"] = params_json;
  if (publisher) {
    publish(!stats.interrupted, 0.0f);
    const auto& p = publisher->stats();
    const double log_s = scans[stats.scans > 0 ? stats.scans - 1 : 0].stamp - t0_log;
    const std::uint64_t sent_bytes = p.tile_bytes + p.meta_bytes + p.pose_bytes;
    const auto sent = static_cast<double>(sent_bytes);
    const auto full = static_cast<double>(p.full_map_bytes);
    extra["dds"] = {
        {"domain", o.domain},
        {"map_id", o.map_id},
        {"epoch", o.epoch},
        {"publish_period_s", o.publish_period},
        {"publishes", p.publishes},
        {"tiles_published", p.tiles},
        {"tile_bytes", p.tile_bytes},
        {"meta_bytes", p.meta_bytes},
        {"pose_bytes", p.pose_bytes},
        {"bytes_total", sent_bytes},
        {"log_duration_s", log_s},
        {"bytes_per_log_s", log_s > 0 ? sent / log_s : 0.0},
        {"full_map_bytes", p.full_map_bytes},
        {"full_map_over_tiles", sent > 0 ? full / sent : 0.0},
        {"write_failures", p.write_failures},
    };
    spdlog::info(
        "published {} tiles, {:.1f} kB in all ({:.0f} B per log second); the whole "
        "map at every publish would be {:.1f} kB ({:.1f}x more)",
        p.tiles, sent / 1e3, extra["dds"]["bytes_per_log_s"].get<double>(), full / 1e3,
        extra["dds"]["full_map_over_tiles"].get<double>());
  }
  try {
    app::write_slam_outputs(out_dir, slam, stats, extra);
  } catch (const std::exception& e) {
    spdlog::error("writing results to {}: {}", out_dir, e.what());
    return 1;
  }
  const auto ms = app::summarize(stats.ms_per_scan);
  spdlog::info("{} scans in {:.1f} s: {:.2f} ms/scan median, {:.2f} p95, {:.2f} max; wrote {}",
               stats.scans, stats.wall_s, ms.median, ms.p95, ms.max, out_dir);

  if (publisher && !stats.interrupted) {
    spdlog::info(
        "log ended: map complete; serving it {}",
        o.linger < 0 ? std::string("until stopped (Ctrl-C)") : fmt::format("for {} s", o.linger));
    const auto until = Clock::now() + std::chrono::duration<double>(o.linger < 0 ? 1e9 : o.linger);
    while (!g_stop.load() && Clock::now() < until) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }
  if (publisher && !publisher->flush(std::chrono::seconds(2))) {
    spdlog::warn("not every follower acknowledged the last samples");
  }
  return stats.interrupted ? 130 : 0;
}
