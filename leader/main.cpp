// esfleet-leader: maps with the (mu+1)-ES SLAM and shares the map over DDS. The scans come from a
// recorded log (--log) or from one robot's DDS scan topic (--scan-topic); both go through the
// same loop (scan_source.hpp). With --offline it only runs a log through the SLAM and writes the
// map, trajectory and statistics; otherwise it also publishes the changed map tiles, the map
// summary and its pose while it maps, and keeps serving the map after the input has ended.

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "app/dds_flags.hpp"
#include "app/param_table.hpp"
#include "app/scan_source.hpp"
#include "app/slam_params.hpp"
#include "app/slam_run.hpp"
#include "checkpoint.hpp"
#include "esfleet/core/slam.hpp"
#include "esfleet/dds/node.hpp"
#include "map_publisher.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

struct OnlineOptions {
  int domain = 0;
  std::string profile;
  std::string secure;  ///< DDS Security directory (docs/security.md); empty = off
  std::string map_id = "map";
  std::uint32_t epoch = 0;  ///< 0 = the start time in seconds, so a restart makes a new epoch
  std::string robot_id = "leader";
  double rate = 0.0;            ///< --log: 0 = as fast as possible, 1 = recorded speed
  double idle_exit = 0.0;       ///< --scan-topic: end after this many idle seconds; 0 = never
  double publish_period = 1.0;  ///< seconds of scan time between publishes
  double linger = -1.0;         ///< seconds to keep serving after the input; < 0 = until stopped
  std::string encoding = "med";
  std::uint64_t full_every = 60;  ///< whole tile every this many publishes (deltas in between)
  double full_period = 60.0;      ///< and at least every this many seconds of scan time
};

/// Parameters whose values differ between a checkpoint and this run, as "name (a -> b)".
std::string changed_params(const std::string& saved_json, const nlohmann::json& now) {
  const nlohmann::json saved = nlohmann::json::parse(saved_json);
  std::string out;
  for (const auto& [name, value] : now.items()) {
    const std::string was = saved.contains(name) ? saved[name].dump() : "(none)";
    if (was != value.dump())
      out += (out.empty() ? "" : ", ") + name + " (" + was + " -> " + value.dump() + ")";
  }
  return out;
}

/// Progress line every this many scans when the total is not known (--scan-topic).
constexpr std::size_t kTopicProgressEvery = 100;

/// stats.json "dds": what map sharing sent, against republishing the whole map; logs a summary.
nlohmann::json dds_stats(const esfleet::leader::PublishStats& p, const OnlineOptions& o,
                         double input_s) {
  const std::uint64_t sent_bytes = p.tile_bytes + p.delta_bytes + p.meta_bytes + p.pose_bytes;
  const auto sent = static_cast<double>(sent_bytes);
  const auto full = static_cast<double>(p.full_map_bytes);
  const double per_s = input_s > 0 ? sent / input_s : 0.0;
  const double ratio = sent > 0 ? full / sent : 0.0;
  spdlog::info(
      "published {} tiles and {} tile deltas, {:.1f} kB in all ({:.0f} B per log second); the "
      "whole map at every publish would be {:.1f} kB ({:.1f}x more)",
      p.tiles, p.deltas, sent / 1e3, per_s, full / 1e3, ratio);
  return {
      {"domain", o.domain},
      {"map_id", o.map_id},
      {"epoch", o.epoch},
      {"publish_period_s", o.publish_period},
      {"publishes", p.publishes},
      {"tiles_published", p.tiles},
      {"tile_bytes", p.tile_bytes},
      {"deltas_published", p.deltas},
      {"delta_bytes", p.delta_bytes},
      {"full_every", o.full_every},
      {"full_period_s", o.full_period},
      {"meta_bytes", p.meta_bytes},
      {"pose_bytes", p.pose_bytes},
      {"bytes_total", sent_bytes},
      {"log_duration_s", input_s},
      {"bytes_per_log_s", per_s},
      {"full_map_bytes", p.full_map_bytes},
      {"full_map_over_tiles", ratio},
      {"write_failures", p.write_failures},
      {"joiner_refreshes", p.joiner_refreshes},
  };
}

}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  using Clock = std::chrono::steady_clock;
  spdlog::set_default_logger(spdlog::stderr_color_st("leader"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App cli{
      "esfleet-leader: 2D laser SLAM with the (mu+1)-Evolution Strategy of Toda & Kubota, "
      "sharing its map over DDS.\n"
      "Maps a CARMEN log (--log) or the scans a robot publishes on esfleet/robots/scan "
      "(--scan-topic) and publishes changed map tiles (whole or as deltas), the map summary and "
      "its pose (topics esfleet/map/tiles, esfleet/map/tile_deltas, esfleet/map/meta, "
      "esfleet/robots/pose); late joiners get the whole "
      "map. With --offline it maps a log without DDS. All write DIR/map.pgm, map.yaml (ROS "
      "map_server), map.png (map with trajectory), trajectory.txt (t x y theta per scan), "
      "map.digest (per-tile counter digests) and stats.json."};
  std::string log_path, scan_robot, out_dir = "out";
  bool offline = false;
  std::size_t max_scans = 0;
  bool paper = false;
  std::string resume_dir;
  std::size_t checkpoint_every = 50;
  OnlineOptions o;
  cli.add_option("--log", log_path, "CARMEN log (.log/.clf, plain or .gz)");
  cli.add_option("--scan-topic", scan_robot,
                 "map the scans robot ID publishes on esfleet/robots/scan (e.g. from "
                 "esfleet-replay) instead of a log");
  cli.add_option("--idle-exit", o.idle_exit,
                 "--scan-topic: end the map once no scan came for S seconds after the first "
                 "(0 = only on Ctrl-C)")
      ->capture_default_str();
  cli.add_option("--out", out_dir, "output directory")->capture_default_str();
  cli.add_flag("--offline", offline, "run the log through the SLAM without DDS");
  cli.add_option("--max-scans", max_scans, "stop after N scans (0 = all)")->capture_default_str();
  cli.add_option("--checkpoint-every", checkpoint_every,
                 "write OUT/checkpoint every N scans and at exit, for --resume (0 = never); a "
                 "leader killed loses at most the N - 1 scans since the last one")
      ->capture_default_str();
  cli.add_option("--resume", resume_dir,
                 "continue the map checkpointed in DIR/checkpoint (same map id, epoch and "
                 "parameters; --log continues after the last checkpointed scan)");
  cli.add_flag("--paper", paper,
               "start from the paper's exact configuration (previous-pose prediction, no "
               "extensions) before applying --config and the flags below");
  auto* dds = cli.add_option_group("DDS", "Map sharing (without --offline)");
  app::add_dds_flags(*dds, o.domain, o.profile, o.secure);
  dds->add_option("--map-id", o.map_id, "name of the shared map")->capture_default_str();
  dds->add_option("--epoch", o.epoch, "map epoch (0 = start time in seconds: a new map)")
      ->capture_default_str();
  dds->add_option("--robot-id", o.robot_id, "id on the pose topic")->capture_default_str();
  dds->add_option("--rate", o.rate,
                  "--log replay speed: 0 = as fast as possible, 1 = recorded speed, 2 = twice")
      ->capture_default_str();
  dds->add_option("--publish-period", o.publish_period,
                  "seconds of scan time between tile publishes (at --rate 1: wall seconds)")
      ->capture_default_str();
  dds->add_option("--linger", o.linger,
                  "after the input: keep serving the map this many seconds (< 0: until Ctrl-C)")
      ->capture_default_str();
  dds->add_option("--encoding", o.encoding,
                  "tile payload encoding: med = predicted residuals + zlib (smallest), varint = "
                  "varints + zlib, raw = 8 bytes per cell")
      ->check(CLI::IsMember({"med", "varint", "raw"}))
      ->capture_default_str();
  dds->add_option("--full-every", o.full_every,
                  "send a changed tile whole every N publishes of it, as a delta against the "
                  "previous publish in between (1 = always whole)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  dds->add_option("--full-period", o.full_period,
                  "send a changed tile whole when its whole copy is S seconds of scan time old")
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
    if (!(o.full_period > 0.0)) throw std::invalid_argument("--full-period must be > 0");
    if (log_path.empty() == scan_robot.empty()) {
      throw std::invalid_argument("give exactly one of --log FILE and --scan-topic ROBOT_ID");
    }
    if (!scan_robot.empty() && offline) {
      throw std::invalid_argument("--offline maps a --log only (--scan-topic needs DDS)");
    }
    if (!scan_robot.empty() && o.rate > 0.0) {
      throw std::invalid_argument("--rate paces a --log; scans from --scan-topic come as sent");
    }
    if (!(o.idle_exit >= 0.0)) throw std::invalid_argument("--idle-exit must be >= 0");
    if (o.idle_exit > 0.0 && scan_robot.empty()) {
      throw std::invalid_argument("--idle-exit needs --scan-topic");
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }
  nlohmann::json params_json;
  for (const auto& [name, value] : params.values()) params_json[name] = value;

  Slam slam(config);
  std::optional<leader::Resumed> resumed;
  if (!resume_dir.empty()) {
    try {
      resumed = leader::load_checkpoint(resume_dir, slam);
      const std::string changed = changed_params(resumed->info.params_json, params_json);
      if (!changed.empty()) {
        throw std::invalid_argument("the SLAM parameters differ from the checkpoint's: " + changed);
      }
      const leader::CheckpointInfo& info = resumed->info;
      if (cli.count("--map-id") > 0 && o.map_id != info.map_id) {
        throw std::invalid_argument("--map-id " + o.map_id + " but the checkpoint's map is " +
                                    info.map_id);
      }
      if (cli.count("--epoch") > 0 && o.epoch != info.epoch) {
        throw std::invalid_argument("--epoch " + std::to_string(o.epoch) +
                                    " but the checkpoint's epoch is " + std::to_string(info.epoch));
      }
      o.map_id = info.map_id;
      o.epoch = info.epoch;
    } catch (const std::exception& e) {
      spdlog::error("--resume {}: {}", resume_dir, e.what());
      return 2;
    }
    spdlog::info(
        "resumed map '{}' epoch {} from {}/checkpoint: {} scans ({}), {} tiles ({} empty ones "
        "the followers may hold), all republished at version {}",
        o.map_id, o.epoch, resume_dir, resumed->info.scans, resumed->info.input,
        slam.map().tile_count(), resumed->tiles_added_empty, resumed->new_version);
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  // Destroyed in reverse: the scan source (its reader) and the publisher before the node.
  std::unique_ptr<dds::Node> node;
  std::unique_ptr<leader::MapPublisher> publisher;
  std::unique_ptr<app::ScanSource> source;
  app::TopicScanSource* topic = nullptr;
  if (!log_path.empty()) {
    try {
      std::vector<LaserScan> scans =
          app::read_log(log_path, reader_options, max_scans, config.tracking.use_odometry, g_stop);
      if (resumed) {
        const std::size_t skip = resumed->info.scans;
        if (skip > scans.size()) {
          throw std::invalid_argument("--resume: the checkpoint has " + std::to_string(skip) +
                                      " scans but " + log_path + " only " +
                                      std::to_string(scans.size()));
        }
        if (resumed->info.input != "log " + log_path) {
          spdlog::warn("the checkpoint mapped {}; continuing with log {}", resumed->info.input,
                       log_path);
        }
        scans.erase(scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(skip));
        spdlog::info("continuing {} at scan {}", log_path, skip);
      }
      source = std::make_unique<app::LogScanSource>(std::move(scans), o.rate);
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
      return 2;
    }
    spdlog::info("{}: {} scans", log_path, source->total());
  }
  for (const auto& [name, value] : params.values()) spdlog::info("  {} = {}", name, value);

  if (!offline) {
    if (o.epoch == 0) {
      o.epoch = static_cast<std::uint32_t>(dds::realtime_ns() / 1'000'000'000);
    }
    try {
      node = std::make_unique<dds::Node>(
          dds::NodeOptions{o.domain, o.profile, "esfleet-leader", o.secure});
      publisher = std::make_unique<leader::MapPublisher>(
          *node, dds::MapIdentity{o.map_id, o.epoch}, o.robot_id,
          o.encoding == "raw"      ? TileEncoding::kRaw
          : o.encoding == "varint" ? TileEncoding::kVarintZlib
                                   : TileEncoding::kMedZlib,
          leader::DeltaPolicy{o.full_every, o.full_period});
      if (!scan_robot.empty()) {
        auto t = std::make_unique<app::TopicScanSource>(*node, scan_robot, o.idle_exit);
        topic = t.get();
        source = std::move(t);
      }
    } catch (const std::exception& e) {
      spdlog::error("DDS: {}", e.what());
      return 2;
    }
    spdlog::info("sharing map '{}' epoch {} on DDS domain {}{}", o.map_id, o.epoch, o.domain,
                 o.profile.empty() ? "" : " with profile " + o.profile);
    if (topic) {
      spdlog::info("mapping the scans of robot '{}' from {}; {}", scan_robot, dds::kScanTopic,
                   o.idle_exit > 0 ? fmt::format("ending {} s after the last one", o.idle_exit)
                                   : std::string("until stopped (Ctrl-C)"));
    }
  }

  // Checkpoints (OUT/checkpoint): the snapshot every --checkpoint-every scans and at exit, the
  // publish journal before every publish that needs it.
  std::optional<leader::Checkpointer> checkpointer;
  nlohmann::json checkpoint_json;
  std::vector<double> checkpoint_ms;
  std::uint64_t checkpoint_bytes = 0;
  bool checkpoint_failed_logged = false;
  if (checkpoint_every > 0) {
    namespace fs = std::filesystem;
    const std::string dir = out_dir + "/checkpoint";
    std::uint64_t generation = 1;
    std::error_code ec;
    if (resumed && fs::equivalent(fs::path(resume_dir) / "checkpoint", dir, ec)) {
      generation = resumed->generation + 1;
    } else if (fs::exists(dir + "/manifest.json")) {
      // A fresh start (a new epoch) over an old checkpoint: keep the old one aside.
      fs::remove_all(dir + ".old", ec);
      fs::rename(dir, dir + ".old", ec);
      spdlog::warn("moved the old checkpoint {} to {}.old (start with --resume {} to continue it)",
                   dir, dir, out_dir);
    }
    try {
      checkpointer.emplace(dir, generation);
      if (resumed) checkpointer->adopt_journal(resumed->journal);
    } catch (const std::exception& e) {
      spdlog::error("checkpoint directory {}: {}", dir, e.what());
      return 2;
    }
  }
  const std::string input_name = log_path.empty() ? "scan-topic " + scan_robot : "log " + log_path;
  auto save_checkpoint = [&](const char* why) {
    if (!checkpointer) return;
    const auto t0 = Clock::now();
    try {
      checkpoint_bytes = checkpointer->save(
          slam, {o.map_id, o.epoch, slam.scans_processed(), input_name, params_json.dump()});
    } catch (const std::exception& e) {
      spdlog::error("checkpoint at scan {} failed: {}", slam.scans_processed(), e.what());
      return;
    }
    checkpoint_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    if (checkpoint_ms.size() == 1 || checkpoint_ms.size() % 20 == 0 || why != nullptr) {
      spdlog::info("checkpoint {} at scan {}{}: {:.0f} kB in {:.1f} ms", checkpoint_ms.size(),
                   slam.scans_processed(), why != nullptr ? fmt::format(" ({})", why) : "",
                   static_cast<double>(checkpoint_bytes) / 1e3, checkpoint_ms.back());
    }
  };
  const std::size_t every =
      source->total() > 0 ? std::max<std::size_t>(1, source->total() / 20) : kTopicProgressEvery;
  std::optional<double> first_stamp;
  double last_stamp = 0.0, last_publish = -1e300;
  const std::string params_dump = params_json.dump();
  auto publish = [&](bool complete, float fitness) {
    if (checkpointer) {
      try {
        checkpointer->reserve(slam.map());
      } catch (const std::exception& e) {
        // Mapping and sharing go on; only a resumed leader could then fail to supersede tiles.
        if (!checkpoint_failed_logged) spdlog::error("publish journal: {}", e.what());
        checkpoint_failed_logged = true;
      }
    }
    publisher->publish(slam.map(), slam.trajectory().back(), fitness, complete,
                       static_cast<std::uint32_t>(slam.scans_processed()), params_dump);
  };
  if (resumed && publisher) {
    // Supersede what the dead leader published now, not at the next scan (which may be long).
    publisher->republish_all(slam.map());
    publish(false, 0.0f);
  }
  const auto stats = app::run_slam(
      slam, *source, max_scans, g_stop,
      [&](const LaserScan& scan, const SlamStep& step, std::size_t done) {
        if (!first_stamp) first_stamp = scan.stamp;
        if (checkpoint_every > 0 && slam.scans_processed() % checkpoint_every == 0) {
          save_checkpoint(nullptr);
        }
        last_stamp = scan.stamp;
        if (publisher && scan.stamp - last_publish >= o.publish_period) {
          publish(false, step.fitness.fitness);
          last_publish = scan.stamp;
        }
        if (done % every == 0 || done == source->total()) {
          spdlog::info("scan {}{}  pose ({:.2f}, {:.2f}, {:.1f} deg)  fitness {:.1f}  tiles {}",
                       done, source->total() > 0 ? fmt::format("/{}", source->total()) : "",
                       step.pose.x, step.pose.y, rad_to_deg(step.pose.theta), step.fitness.fitness,
                       slam.map().tile_count());
        }
      });
  save_checkpoint(stats.interrupted ? "interrupted" : "end of input");
  if (checkpointer) {
    const app::Summary c = app::summarize(checkpoint_ms);
    checkpoint_json = {{"dir", checkpointer->dir()},
                       {"every", checkpoint_every},
                       {"written", checkpoint_ms.size()},
                       {"ms_median", c.median},
                       {"ms_max", c.max},
                       {"bytes_last", checkpoint_bytes},
                       {"version_ceiling", checkpointer->journal().version_ceiling}};
  }
  if (stats.scans == 0 && !resumed) {
    spdlog::warn("no scan received: nothing to save");
    return stats.interrupted ? 130 : 1;
  }
  if (stats.interrupted) {
    spdlog::warn("interrupted after {} scans: saving what we have", stats.scans);
  }

  nlohmann::json extra;
  if (topic) {
    const app::TopicScanStats t = topic->stats();
    extra["scan_topic"] = {{"robot_id", scan_robot},      {"received", t.received},
                           {"malformed", t.malformed},    {"other_robots", t.other_robots},
                           {"seq_gaps", t.seq_gaps},      {"seq_restarts", t.seq_restarts},
                           {"max_queue", t.max_queue},    {"idle_exit_s", o.idle_exit},
                           {"ended_idle", topic->ended()}};
    spdlog::info(
        "scan topic: {} scans of '{}' received, {} malformed, {} missing (seq), "
        "{} of other robots; at most {} waiting for the SLAM",
        t.received, scan_robot, t.malformed, t.seq_gaps, t.other_robots, t.max_queue);
  } else {
    extra["log"] = log_path;
  }
  extra["paper_mode"] = paper;
  if (checkpointer) extra["checkpoint"] = checkpoint_json;
  if (resumed) {
    extra["resumed"] = {{"from", resume_dir},
                        {"scans", resumed->info.scans},
                        {"tiles_added_empty", resumed->tiles_added_empty},
                        {"version", resumed->new_version}};
  }
  extra["parameters"] = params_json;
  if (publisher) {
    publish(!stats.interrupted, 0.0f);
    extra["dds"] = dds_stats(publisher->stats(), o, first_stamp ? last_stamp - *first_stamp : 0);
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
    const std::string why = !topic           ? std::string("log ended")
                            : topic->ended() ? fmt::format("no scan for {} s", o.idle_exit)
                                             : fmt::format("{} scans mapped", stats.scans);
    spdlog::info(
        "{}: map complete; serving it {}", why,
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
