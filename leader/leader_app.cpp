#include "leader_app.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <system_error>
#include <thread>
#include <vector>

#include "app/program.hpp"
#include "app/summary.hpp"
#include "esfleet/core/clock.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/dds/to_msg.hpp"

namespace esfleet::leader {

namespace {

/// Progress line every this many scans when the total is not known (--scan-topic).
constexpr std::size_t kTopicProgressEvery = 100;

nlohmann::json params_json(const LeaderOptions& o) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [name, value] : o.parameters) j[name] = value;
  return j;
}

/// stats.json "dds" "publisher": the hand-over from the mapping thread to the publisher thread
/// (leader/map_publisher.hpp). handover_s is what publishing cost the mapping thread; encode_s
/// and write_s what the publisher thread spent instead.
nlohmann::json publisher_json(const PublishStats& p) {
  return {{"rounds", p.rounds},
          {"tiles_handed_over", p.tiles_handed_over},
          {"coalesced", p.coalesced},
          {"queue_high_water", p.queue_high_water},
          {"handover_s", p.handover_s},
          {"encode_s", p.encode_s},
          {"write_s", p.write_s},
          {"ack_wait_s", p.ack_wait_s},
          {"ack_timeouts", p.ack_timeouts},
          {"max_wait_s", p.max_wait_s},
          {"mid_round_updates", p.mid_round_updates}};
}

/// stats.json "dds": what map sharing sent, against republishing the whole map; logs a summary.
nlohmann::json dds_stats(const PublishStats& p, const LeaderOptions& o, double input_s) {
  const std::uint64_t sent_bytes = p.tile_bytes + p.delta_bytes + p.meta_bytes + p.pose_bytes;
  const auto sent = static_cast<double>(sent_bytes);
  const auto full = static_cast<double>(p.full_map_bytes);
  const double per_s = input_s > 0 ? sent / input_s : 0.0;
  const double ratio = sent > 0 ? full / sent : 0.0;
  spdlog::info(
      "published {} tiles and {} tile deltas, {:.1f} kB in all ({:.0f} B per log second); the "
      "whole map at every publish would be {:.1f} kB ({:.1f}x more)",
      p.tiles, p.deltas, sent / 1e3, per_s, full / 1e3, ratio);
  spdlog::info(
      "publisher thread: {} rounds for {} hand-overs, {} of {} tile copies coalesced (at most {} "
      "waiting); mapping thread {:.3f} s handing over, publisher {:.3f} s encoding, {:.3f} s "
      "writing, {:.1f} s waiting for acknowledgments",
      p.rounds, p.publishes, p.coalesced, p.tiles_handed_over, p.queue_high_water, p.handover_s,
      p.encode_s, p.write_s, p.ack_wait_s);
  return {
      {"domain", o.domain},
      {"map_id", *o.map_id},
      {"epoch", *o.epoch},
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
      {"publisher", publisher_json(p)},
  };
}

}  // namespace

LeaderApp::LeaderApp(LeaderOptions options, const std::atomic<bool>& stop)
    : o_(std::move(options)), stop_(stop), params_json_(params_json(o_).dump()), slam_(o_.slam) {
  if (o_.serving_map()) {  // a map server: no SLAM, no scans, no checkpoints
    load_map();
    open_dds();
    return;
  }
  if (!o_.resume_dir.empty()) resume_checkpoint();
  if (!o_.log.empty()) read_log();
  spdlog::info("SLAM parameters{}: {}{}; all {} in stats.json and at --log-level debug",
               o_.resume_dir.empty() ? "" : " (the checkpoint's)",
               o_.paper ? "the paper's configuration, " : "", o_.parameter_changes,
               o_.parameters.size());
  for (const std::string& note : o_.resume_notes) spdlog::warn("--resume: {}", note);
  for (const auto& [name, value] : o_.parameters) spdlog::debug("  {} = {}", name, value);
  if (!o_.offline) open_dds();
  if (o_.checkpoint_every > 0) open_checkpoints();
  progress_every_ =
      source_->total() > 0 ? std::max<std::size_t>(1, source_->total() / 20) : kTopicProgressEvery;
}

LeaderApp::~LeaderApp() = default;  // members in reverse: checkpoints, source, publisher, node

void LeaderApp::resume_checkpoint() {
  app::setup_step("--resume " + o_.resume_dir, [&] {
    // The parameters are the checkpoint's already (finish_leader_options).
    resumed_ = load_checkpoint(o_.resume_dir, slam_);
    const CheckpointInfo& info = resumed_->info;
    if (o_.map_id && *o_.map_id != info.map_id) {
      throw std::invalid_argument("--map-id " + *o_.map_id + " but the checkpoint's map is " +
                                  info.map_id);
    }
    if (o_.epoch && *o_.epoch != info.epoch) {
      throw std::invalid_argument("--epoch " + std::to_string(*o_.epoch) +
                                  " but the checkpoint's epoch is " + std::to_string(info.epoch));
    }
    o_.map_id = info.map_id;
    o_.epoch = info.epoch;
  });
  spdlog::info(
      "resumed map '{}' epoch {} from {}/checkpoint: {} scans ({}), {} tiles ({} empty ones "
      "the followers may hold), all republished at version {}",
      *o_.map_id, *o_.epoch, o_.resume_dir, resumed_->info.scans, resumed_->info.input,
      slam_.map().tile_count(), resumed_->tiles_added_empty, resumed_->new_version);
}

void LeaderApp::load_map() {
  app::setup_step("", [&] {
    try {
      served_ = load_served_map(o_.map, o_.slam);
    } catch (const std::exception& e) {
      throw std::runtime_error(app::name_flag("--map", o_.map, e.what()));
    }
  });
  const ServedMap& m = *served_;
  for (const std::string& dir : m.dirs) {
    std::error_code ec;
    if (std::filesystem::equivalent(o_.out_dir, dir, ec)) {
      throw app::UsageError("--out " + o_.out_dir + ": the map served (--map " + o_.map +
                            ") is there; give --out another directory (the map server writes "
                            "stats.json, map.digest, map.pgm and map.yaml into it)");
    }
  }
  const CellClasses cells = cell_classes(m.map);
  if (m.checkpoint) {
    if (!o_.map_id) o_.map_id = m.checkpoint->map_id;
    params_json_ = m.checkpoint->params_json;
    spdlog::info(
        "serving the checkpoint {} (map '{}', epoch {}, {} scans of {}) as saved: {} tiles of "
        "{} cells, {} m per cell",
        m.file, m.checkpoint->map_id, m.checkpoint->epoch, m.checkpoint->scans, m.checkpoint->input,
        m.map.tile_count(), m.map.cells_per_tile(), m.map.cell_size());
  } else {
    params_json_ = "{}";
    spdlog::info(
        "serving the ROS map {}: cell value v -> hit round(v/20), err 5 - hit; {} tiles of {} "
        "cells, {} m per cell",
        m.file, m.map.tile_count(), m.map.cells_per_tile(), m.map.cell_size());
    if (!m.placement->aligned()) {
      spdlog::warn(
          "{}: the origin is not a whole number of {} m cells: the map moves by ({:+.4f}, "
          "{:+.4f}) m (each pixel goes to the cell holding its centre)",
          m.file, m.map.cell_size(), m.placement->shift_x, m.placement->shift_y);
    }
    if (m.origin_theta != 0.0) {
      spdlog::warn("{}: origin yaw {} rad ignored (as most ROS tools do)", m.file, m.origin_theta);
    }
  }
  spdlog::info("map cells (as ROS reads them): {} occupied, {} free, {} unknown", cells.occupied,
               cells.free, cells.unknown);
  if (m.map.known_bounds().empty) spdlog::warn("{}: the map has no known cell", m.file);
}

void LeaderApp::read_log() {
  app::setup_step("", [&] {
    std::vector<LaserScan> scans =
        app::read_log(o_.log, o_.reader, o_.max_scans, o_.slam.tracking.use_odometry, stop_);
    if (resumed_) {
      const std::size_t skip = resumed_->info.scans;
      if (skip > scans.size()) {
        throw std::invalid_argument("--resume: the checkpoint has " + std::to_string(skip) +
                                    " scans but " + o_.log + " only " +
                                    std::to_string(scans.size()));
      }
      if (resumed_->info.input != o_.input_name()) {
        spdlog::warn("the checkpoint mapped {}; continuing with log {}", resumed_->info.input,
                     o_.log);
      }
      scans.erase(scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(skip));
      spdlog::info("continuing {} at scan {}", o_.log, skip);
    }
    source_ = std::make_unique<app::LogScanSource>(std::move(scans), o_.rate);
  });
  spdlog::info("{}: {} scans", o_.log, source_->total());
}

void LeaderApp::open_dds() {
  if (!o_.map_id) o_.map_id = "map";
  if (!o_.epoch) o_.epoch = static_cast<std::uint32_t>(realtime_ns() / 1'000'000'000);
  app::setup_step("DDS", [&] {
    node_ = std::make_unique<dds::Node>(
        dds::NodeOptions{o_.domain, o_.profile, "esfleet-leader", o_.secure});
    publisher_ = std::make_unique<MapPublisher>(
        *node_, mapshare::MapIdentity{*o_.map_id, *o_.epoch}, o_.robot_id, o_.encoding,
        mapshare::DeltaPolicy{o_.full_every, o_.full_period});
    if (o_.accept_contributions) {
      intake_ = std::make_unique<ContributionIntake>(*node_,
                                                     mapshare::MapIdentity{*o_.map_id, *o_.epoch});
    }
    if (!o_.scan_robot.empty()) {
      auto t = std::make_unique<app::TopicScanSource>(*node_, o_.scan_robot, o_.idle_exit);
      topic_ = t.get();
      source_ = std::move(t);
    }
  });
  if (o_.ros.any()) open_ros();
  spdlog::info("sharing map '{}' epoch {} on DDS domain {}{}", *o_.map_id, *o_.epoch, o_.domain,
               o_.profile.empty() ? "" : " with profile " + o_.profile);
  if (intake_) {
    spdlog::info("accepting the scans followers contribute on {} (answers on {})",
                 dds::kContributionTopic, dds::kContributionStatusTopic);
  }
  if (topic_ != nullptr) {
    spdlog::info("mapping the scans of robot '{}' from {}; {}", o_.scan_robot, dds::kScanTopic,
                 o_.idle_exit > 0 ? fmt::format("ending {} s after the last one", o_.idle_exit)
                                  : std::string("until stopped (Ctrl-C)"));
  }
}

void LeaderApp::open_ros() {
  const app::RosNames names = app::resolve_ros_names(o_.ros, o_.robot_id);
  app::setup_step("ROS 2 topics", [&] {
    if (!names.scan_topic.empty()) {
      auto s = std::make_unique<app::RosScanSource>(*node_, names, o_.ros, o_.idle_exit);
      ros_scan_ = s.get();
      source_ = std::move(s);
    }
    if (o_.ros.outputs) {
      ros_map_ = std::make_unique<RosMapOutput>(*node_, names.map_frame, o_.ros.map_period);
      if (!served_) ros_pose_ = std::make_unique<app::RosPoseOutput>(*node_, names);
    }
  });
  if (ros_scan_ != nullptr) {
    spdlog::info("mapping the sensor_msgs/LaserScan of {}{}; {}", names.scan_topic,
                 names.odom_from_tf         ? " with odometry from /tf"
                 : names.odom_topic.empty() ? " (laser only)"
                                            : " with odometry from " + names.odom_topic,
                 o_.idle_exit > 0 ? fmt::format("ending {} s after the last one", o_.idle_exit)
                                  : std::string("until stopped (Ctrl-C)"));
  }
  if (ros_map_ && served_) {
    spdlog::info("ROS 2: /map (frame {}) at once and every {} s", names.map_frame,
                 o_.ros.map_period);
  } else if (ros_map_) {
    spdlog::info(
        "ROS 2: /map every {} s of scan time, /map_updates in between, pose on {}, TF "
        "{} -> {}",
        o_.ros.map_period, names.pose_topic, names.map_frame, names.odom_frame);
  }
}

void LeaderApp::open_checkpoints() {
  const std::string dir = o_.out_dir + "/checkpoint";
  app::setup_step("checkpoint directory " + dir, [&] {
    checkpoints_.emplace(o_.out_dir, o_.checkpoint_every,
                         CheckpointInfo{o_.map_id.value_or("map"), o_.epoch.value_or(0), 0,
                                        o_.input_name(), params_json_},
                         o_.resume_dir, resumed_ ? &*resumed_ : nullptr);
  });
}

void LeaderApp::publish(bool complete, float fitness) {
  if (checkpoints_) checkpoints_->reserve(slam_.map());
  // Contributed key scans count as scans of the map (the summary's progress).
  publisher_->publish(
      slam_.map(), slam_.trajectory().back(), fitness, complete,
      static_cast<std::uint32_t>(slam_.scans_processed() + slam_.contributed_keys()), params_json_);
  if (ros_map_) ros_map_->publish(slam_.map(), slam_.trajectory().back().stamp, complete);
}

void LeaderApp::on_scan(const LaserScan& scan, const SlamStep& step, std::size_t done) {
  if (!first_stamp_) first_stamp_ = scan.stamp;
  if (checkpoints_) checkpoints_->after_scan(slam_);
  last_stamp_ = scan.stamp;
  // Contributions between own scans: their tiles go out with the next publish.
  if (intake_) intake_->process(slam_);
  if (ros_pose_) {
    const double cpu0 = thread_cpu_seconds();
    ros_pose_->publish(TimedPose{scan.stamp, step.pose}, scan.odometry,
                       ros_scan_ != nullptr ? ros_scan_->mount() : Pose2{},
                       app::pose_sigma(true, step.fitness.agreement(), slam_.map().cell_size()));
    ros_pose_cpu_s_ += thread_cpu_seconds() - cpu0;
  }
  if (publisher_ && scan.stamp - last_publish_ >= o_.publish_period) {
    publish(false, step.fitness.fitness);
    last_publish_ = scan.stamp;
  }
  if (done % progress_every_ == 0 || done == source_->total()) {
    spdlog::info("scan {}{}  pose ({:.2f}, {:.2f}, {:.1f} deg)  fitness {:.1f}  tiles {}", done,
                 source_->total() > 0 ? fmt::format("/{}", source_->total()) : "", step.pose.x,
                 step.pose.y, rad_to_deg(step.pose.theta), step.fitness.fitness,
                 slam_.map().tile_count());
  }
}

int LeaderApp::run() {
  if (served_) return serve_map();
  if (resumed_ && publisher_) {
    // Supersede what the dead leader published now, not at the next scan (which may be long).
    publisher_->republish_all(slam_.map());
    publish(false, 0.0f);
  }
  const SlamRunStats stats = run_slam(slam_, *source_, o_.max_scans, stop_,
                                      [this](const LaserScan& scan, const SlamStep& s,
                                             std::size_t done) { on_scan(scan, s, done); });
  // The final pass once the input ended (not on Ctrl-C: stopping stays quick). The tiles it
  // changes go out with the last publish (extra_stats).
  if (!stats.interrupted && stats.scans > 0) {
    final_pass_ = slam_.finish();
    if (final_pass_->tried > 0) {
      // The ICP's counts only when it ran (--loop-final-icp-neighbours).
      const std::string icp =
          final_pass_->icp_tried == 0
              ? std::string()
              : fmt::format(
                    "; {} of {} pairs of successive key scans aligned by ICP ({} held "
                    "along a corridor)",
                    final_pass_->icp_aligned, final_pass_->icp_tried, final_pass_->icp_held);
      spdlog::info(
          "final pass: {} key scans matched against their surroundings, {} matches, {} "
          "kept{}; {:.1f} s",
          final_pass_->tried, final_pass_->matched, final_pass_->kept, icp,
          final_pass_->ms / 1000.0);
    }
  }
  if (checkpoints_) checkpoints_->save(slam_, stats.interrupted ? "interrupted" : "end of input");
  if (stats.scans == 0 && !resumed_) {
    spdlog::warn("no scan received: nothing to save");
    return stats.interrupted ? app::kExitInterrupted : app::kExitFailure;
  }
  if (stats.interrupted) {
    spdlog::warn("interrupted after {} scans: saving what we have", stats.scans);
  }
  if (!write_outputs(stats)) return app::kExitFailure;
  const app::Summary ms = app::summarize(stats.ms_per_scan);
  spdlog::info("{} scans in {:.1f} s: {:.2f} ms/scan median, {:.2f} p95, {:.2f} max; wrote {}",
               stats.scans, stats.wall_s, ms.median, ms.p95, ms.max, o_.out_dir);
  // Many weak matches usually mean the scans are far apart (a key-scan log, dropped scans, a
  // fast robot): say what helps.
  if (!slam_.config().recovery.enabled && stats.scans >= 20 &&
      stats.weak_matches * 10 >= stats.scans) {
    spdlog::warn(
        "{} of {} scans agreed poorly with the map: if the scans are far apart (key scans, "
        "dropped scans, a fast robot), try --recovery on (docs/slam.md)",
        stats.weak_matches, stats.scans);
  }
  if (!stats.poor_stretches.empty()) {
    std::string where;
    for (const PoorStretch& p : stats.poor_stretches) {
      where += fmt::format("{}{}-{}", where.empty() ? "" : ", ", p.first, p.last);
    }
    spdlog::warn(
        "the scans matched the map poorly in {} stretch{} (scans {}; stats.json poor_stretches): "
        "the map may be wrong from there on. Scans far apart or a fast robot: keep more scans; "
        "wheel odometry in the log: --odometry on (docs/slam.md)",
        stats.poor_stretches.size(), stats.poor_stretches.size() == 1 ? "" : "es", where);
  }
  if (publisher_ && !stats.interrupted) {
    const std::size_t accepted = serve(stats);
    if (intake_) {
      // Contributions may have changed the map while serving, and their counts did: the
      // results again, as they are now.
      if (checkpoints_ && accepted > 0) checkpoints_->save(slam_, "contributions after the input");
      if (!write_outputs(stats)) return app::kExitFailure;
      spdlog::info(
          "wrote {} again: {} contributions accepted while serving; the map holds {} "
          "contributed scans in {} tiles",
          o_.out_dir, accepted, slam_.contributed_keys(), slam_.map().tile_count());
    }
  }
  if (publisher_ && !publisher_->flush(std::chrono::seconds(2))) {
    spdlog::warn("not every follower acknowledged the last samples");
  }
  return stats.interrupted ? app::kExitInterrupted : app::kExitOk;
}

bool LeaderApp::write_outputs(const SlamRunStats& stats) {
  const nlohmann::json extra = extra_stats(stats);
  try {
    write_slam_outputs(o_.out_dir, slam_, stats, extra);
  } catch (const std::exception& e) {
    spdlog::error("writing results to {}: {}", o_.out_dir, e.what());
    return false;
  }
  return true;
}

nlohmann::json LeaderApp::extra_stats(const SlamRunStats& stats) {
  nlohmann::json extra;
  if (topic_ != nullptr) {
    const app::TopicScanStats t = topic_->stats();
    extra["scan_topic"] = {{"robot_id", o_.scan_robot},    {"received", t.received},
                           {"malformed", t.malformed},     {"other_robots", t.other_robots},
                           {"seq_gaps", t.seq_gaps},       {"seq_restarts", t.seq_restarts},
                           {"max_queue", t.max_queue},     {"idle_exit_s", o_.idle_exit},
                           {"ended_idle", topic_->ended()}};
    spdlog::info(
        "scan topic: {} scans of '{}' received, {} malformed, {} missing (seq), "
        "{} of other robots; at most {} waiting for the SLAM",
        t.received, o_.scan_robot, t.malformed, t.seq_gaps, t.other_robots, t.max_queue);
  } else {
    extra["log"] = o_.log;
  }
  if (ros_scan_ != nullptr) {
    extra["ros_scan"] = ros_scan_->stats().json();
    extra["ros_scan"]["topic"] = o_.ros.scan_topic;
  }
  extra["paper_mode"] = o_.paper;
  if (final_pass_) {
    extra["final_pass"] = {{"key_scans_tried", final_pass_->tried},
                           {"matched", final_pass_->matched},
                           {"kept", final_pass_->kept},
                           {"s", final_pass_->ms / 1000.0}};
  }
  if (checkpoints_) extra["checkpoint"] = checkpoints_->stats();
  if (resumed_) {
    extra["resumed"] = {{"from", o_.resume_dir},
                        {"scans", resumed_->info.scans},
                        {"tiles_added_empty", resumed_->tiles_added_empty},
                        {"version", resumed_->new_version}};
  }
  extra["parameters"] = params_json(o_);
  if (publisher_) {
    publish(!stats.interrupted, 0.0f);
    // The figures include the last round (bounded: a slow link may still be acknowledging the
    // round before it, and stopping stays quick).
    if (!publisher_->drain(std::chrono::seconds(stats.interrupted ? 1 : 5))) {
      spdlog::warn("the publisher thread has not written the last publish yet");
    }
    extra["dds"] =
        dds_stats(publisher_->stats(), o_, first_stamp_ ? last_stamp_ - *first_stamp_ : 0);
  }
  if (ros_map_) extra["ros"] = ros_stats(stats);
  if (intake_) {
    intake_->log_summary();
    extra["contributions"] = intake_->json();
    extra["contributed_keys"] = slam_.contributed_keys();
  }
  return extra;
}

nlohmann::json LeaderApp::ros_stats(const SlamRunStats& stats) const {
  const RosMapStats& m = ros_map_->stats();
  double slam_ms = 0.0;
  for (const double ms : stats.ms_per_scan) slam_ms += ms;
  const double ros_cpu_s = m.cpu_s + ros_pose_cpu_s_;
  const double share = slam_ms > 0 ? ros_cpu_s / (slam_ms / 1e3) : 0.0;
  const double input_s = first_stamp_ ? last_stamp_ - *first_stamp_ : 0.0;
  const auto sent = static_cast<double>(m.map_bytes + m.update_bytes);
  const auto whole = static_cast<double>(m.whole_every_publish_bytes);
  spdlog::info(
      "ROS 2: {} /map ({:.1f} kB) and {} /map_updates ({:.1f} kB), {:.0f} B per log second; a "
      "whole /map at every publish would be {:.1f} kB ({:.1f}x more); ROS outputs took {:.2f} s "
      "CPU, {:.1f} % of the SLAM's time",
      m.maps, static_cast<double>(m.map_bytes) / 1e3, m.updates,
      static_cast<double>(m.update_bytes) / 1e3, input_s > 0 ? sent / input_s : 0.0, whole / 1e3,
      sent > 0 ? whole / sent : 0.0, ros_cpu_s, 100.0 * share);
  nlohmann::json j = m.json();
  j["map_period_s"] = o_.ros.map_period;
  j["bytes_per_log_s"] = input_s > 0 ? sent / input_s : 0.0;
  j["pose_and_tf_bytes"] = ros_pose_->bytes_written();
  j["pose_cpu_s"] = ros_pose_cpu_s_;
  j["cpu_share_of_slam"] = share;
  return j;
}

std::size_t LeaderApp::serve(const SlamRunStats& stats) {
  const bool from_topic = topic_ != nullptr || ros_scan_ != nullptr;
  const std::string why = !from_topic        ? std::string("log ended")
                          : source_->ended() ? fmt::format("no scan for {} s", o_.idle_exit)
                                             : fmt::format("{} scans mapped", stats.scans);
  spdlog::info(
      "{}: map complete; serving it {}", why,
      o_.linger < 0 ? std::string("until stopped (Ctrl-C)") : fmt::format("for {} s", o_.linger));
  using Clock = std::chrono::steady_clock;
  const auto until = Clock::now() + std::chrono::duration<double>(o_.linger < 0 ? 1e9 : o_.linger);
  std::size_t accepted = 0, since_checkpoint = 0;
  while (!stop_.load() && Clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(intake_ ? 50 : 100));
    if (!intake_) continue;
    // The map is final but contributions still change it: publish what they changed (the
    // summary stays complete, its version and scans follow).
    const std::size_t n = intake_->process(slam_);
    if (n > 0) {
      accepted += n;
      since_checkpoint += n;
      publish(true, 0.0f);
    }
    // A leader killed while serving keeps the contributions up to its last checkpoint: one
    // every --checkpoint-every accepted contributions, as for its own scans.
    if (checkpoints_ && since_checkpoint >= o_.checkpoint_every) {
      checkpoints_->save(slam_, "contributions while serving");
      since_checkpoint = 0;
    }
  }
  return accepted;
}

std::size_t LeaderApp::publish_served(bool tiles, bool ros) {
  const double now = static_cast<double>(realtime_ns()) * 1e-9;
  const auto scans =
      static_cast<std::uint32_t>(served_->checkpoint ? served_->checkpoint->scans : 0);
  std::size_t handed_over = 0;
  if (tiles) handed_over = publisher_->publish_map(served_->map, now, true, scans, params_json_);
  if (ros && ros_map_) ros_map_->publish(served_->map, now, true);
  return handed_over;
}

int LeaderApp::serve_map() {
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  publisher_->republish_all(served_->map);  // every tile whole in the first publish
  const std::size_t handed_over = publish_served(true, true);
  spdlog::info(
      "published map '{}' epoch {}: {} tiles, complete; serving it {}", *o_.map_id, *o_.epoch,
      handed_over,
      o_.linger < 0 ? std::string("until stopped (Ctrl-C)") : fmt::format("for {} s", o_.linger));
  int code = app::kExitOk;
  try {
    std::filesystem::create_directories(o_.out_dir);
    save_ros_map(served_->map, o_.out_dir, "map");
    write_file_atomically(o_.out_dir + "/map.digest", map_digest(served_->map));
  } catch (const std::exception& e) {
    spdlog::error("writing the served map to {}: {}", o_.out_dir, e.what());
    code = app::kExitFailure;
  }
  const auto period = [](double s) { return std::chrono::duration<double>(s); };
  const auto until = start + period(o_.linger < 0 ? 1e9 : o_.linger);
  auto last_publish = start;
  auto last_ros = start;
  while (!stop_.load() && Clock::now() < until) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    // The summary (and the tiles a late joiner may lack) every publish period, /map every
    // ROS map period.
    const auto now = Clock::now();
    const bool tiles = now - last_publish >= period(o_.publish_period);
    const bool ros = ros_map_ && now - last_ros >= period(o_.ros.map_period);
    if (tiles) last_publish = now;
    if (ros) last_ros = now;
    if (tiles || ros) publish_served(tiles, ros);
  }
  const double served_s = std::chrono::duration<double>(Clock::now() - start).count();
  const char* ended = stop_.load() ? "signal" : "linger";
  if (!publisher_->flush(std::chrono::seconds(2))) {
    spdlog::warn("not every follower acknowledged the last samples");
  }
  const PublishStats p = publisher_->stats();
  spdlog::info("served the map for {:.1f} s ({}): {} publishes, {} tiles, {:.1f} kB", served_s,
               ended, p.publishes, p.tiles, static_cast<double>(p.tile_bytes + p.meta_bytes) / 1e3);
  try {
    write_file_atomically(o_.out_dir + "/stats.json", served_stats(served_s, ended).dump(2) + "\n");
  } catch (const std::exception& e) {
    spdlog::error("writing {}/stats.json: {}", o_.out_dir, e.what());
    code = app::kExitFailure;
  }
  return code;
}

nlohmann::json LeaderApp::served_stats(double served_s, const char* ended) const {
  const ServedMap& m = *served_;
  const CellClasses cells = cell_classes(m.map);
  const PublishStats p = publisher_->stats();
  nlohmann::json j = {
      {"source", m.path},
      {"kind", to_string(m.kind)},
      {"file", m.file},
      {"map_id", *o_.map_id},
      {"epoch", *o_.epoch},
      {"complete", true},
      {"scans", m.checkpoint ? m.checkpoint->scans : 0},
      {"tiles", m.map.tile_count()},
      {"tile_edge", m.map.tile_edge()},
      {"cell_size", m.map.cell_size()},
      {"cells", {{"occupied", cells.occupied}, {"free", cells.free}, {"unknown", cells.unknown}}},
      {"served_s", served_s},
      {"ended", ended},
      {"publishes", p.publishes},
      {"dds",
       {{"domain", o_.domain},
        {"publish_period_s", o_.publish_period},
        {"tiles_published", p.tiles},
        {"tile_bytes", p.tile_bytes},
        {"meta_bytes", p.meta_bytes},
        {"bytes_total", p.tile_bytes + p.delta_bytes + p.meta_bytes},
        {"joiner_refreshes", p.joiner_refreshes},
        {"write_failures", p.write_failures}}},
  };
  if (m.checkpoint) {
    j["checkpoint"] = {{"map_id", m.checkpoint->map_id},
                       {"epoch", m.checkpoint->epoch},
                       {"scans", m.checkpoint->scans},
                       {"input", m.checkpoint->input}};
  }
  if (m.placement) {
    j["origin_shift_m"] = {m.placement->shift_x, m.placement->shift_y};
    j["origin_yaw_ignored_rad"] = m.origin_theta;
  }
  if (ros_map_) {
    j["ros"] = ros_map_->stats().json();
    j["ros"]["map_period_s"] = o_.ros.map_period;
  }
  return j;
}

}  // namespace esfleet::leader
