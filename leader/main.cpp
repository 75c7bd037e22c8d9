// esfleet-leader: maps with the (mu+1)-ES SLAM. With --offline it runs a recorded log through
// the SLAM and writes the map, trajectory and statistics; the DDS service comes in a later step.

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "app/param_table.hpp"
#include "app/slam_params.hpp"
#include "app/slam_run.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/slam.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  spdlog::set_default_logger(spdlog::stderr_color_st("leader"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App cli{
      "esfleet-leader: 2D laser SLAM with the (mu+1)-Evolution Strategy of Toda & Kubota.\n"
      "Offline mode runs a CARMEN log through the SLAM and writes DIR/map.pgm, map.yaml (ROS "
      "map_server), map.png (map with trajectory), trajectory.txt (t x y theta per scan) and "
      "stats.json."};
  std::string log_path, out_dir = "out";
  bool offline = false;
  std::size_t max_scans = 0;
  bool paper = false;
  cli.add_option("--log", log_path, "CARMEN log (.log/.clf, plain or .gz)")->required();
  cli.add_option("--out", out_dir, "output directory")->capture_default_str();
  cli.add_flag("--offline", offline, "run the log through the SLAM without DDS");
  cli.add_option("--max-scans", max_scans, "stop after N scans (0 = all)")->capture_default_str();
  cli.add_flag("--paper", paper,
               "start from the paper's exact configuration (previous-pose prediction, no "
               "extensions) before applying --config and the flags below");

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
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  if (!offline) {
    spdlog::error("only --offline is implemented so far");
    return 2;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  std::vector<LaserScan> scans;
  bool corrected_log = false;
  try {
    CarmenReader reader(log_path, reader_options);
    while (auto scan = reader.next_scan()) {
      scans.push_back(std::move(*scan));
      if (max_scans > 0 && scans.size() >= max_scans) break;
      if (g_stop.load()) break;
    }
    corrected_log = reader.saw_corrected_poses();
    if (scans.empty()) throw LogError(log_path, 0, "no laser scans (FLASER/ROBOTLASER1) in file");
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  if (corrected_log && config.use_odometry) {
    spdlog::warn(
        "{} is a GMapping-corrected log: its odometry fields are corrected poses, so "
        "--odometry on makes the result meaningless. Run it laser-only.",
        log_path);
  }
  spdlog::info("{}: {} scans", log_path, scans.size());
  for (const auto& [name, value] : params.values()) spdlog::info("  {} = {}", name, value);

  Slam slam(config);
  const std::size_t every = std::max<std::size_t>(1, scans.size() / 20);
  const auto stats = app::run_slam(
      slam, scans, &g_stop, [&](std::size_t done, std::size_t total, const SlamStep& step) {
        if (done % every == 0 || done == total) {
          spdlog::info("scan {}/{}  pose ({:.2f}, {:.2f}, {:.1f} deg)  fitness {:.1f}  tiles {}",
                       done, total, step.pose.x, step.pose.y, rad_to_deg(step.pose.theta),
                       step.fitness.fitness, slam.map().tile_count());
        }
      });
  if (stats.interrupted)
    spdlog::warn("interrupted after {} scans: saving what we have", stats.scans);

  nlohmann::json extra;
  extra["log"] = log_path;
  extra["paper_mode"] = paper;
  for (const auto& [name, value] : params.values()) extra["parameters"][name] = value;
  try {
    app::write_slam_outputs(out_dir, slam, stats, extra);
  } catch (const std::exception& e) {
    spdlog::error("writing results to {}: {}", out_dir, e.what());
    return 1;
  }
  const auto ms = app::summarize(stats.ms_per_scan);
  spdlog::info("{} scans in {:.1f} s: {:.2f} ms/scan median, {:.2f} p95, {:.2f} max; wrote {}",
               stats.scans, stats.wall_s, ms.median, ms.p95, ms.max, out_dir);
  return stats.interrupted ? 130 : 0;
}
