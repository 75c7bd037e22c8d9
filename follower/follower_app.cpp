#include "follower_app.hpp"

#include <spdlog/spdlog.h>

#include <csignal>
#include <filesystem>
#include <optional>
#include <thread>

#include "app/program.hpp"
#include "app/summary.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/core/map_png.hpp"
#include "esfleet/core/ros_map_writer.hpp"
#include "esfleet/core/tile_codec.hpp"
#include "esfleet/core/trajectory_io.hpp"
#include "esfleet/dds/to_msg.hpp"

namespace esfleet::follower {

namespace {

std::atomic<bool> g_save{false};
extern "C" void on_save_signal(int) { g_save.store(true); }

/// Nothing from any leader after this long: say what is likely wrong, once.
constexpr double kNoMapWarnS = 10.0;
/// How long a localising follower waits for a final map to arrive whole (a late joiner of a
/// busy host took some 30 s for 224 tiles) before it localises in the part it holds.
constexpr double kMapArrivalGraceS = 60.0;

GridMapConfig local_map_config(const LocaliserConfig& c) {
  GridMapConfig local;
  local.pyramid_levels = std::max(c.search.coarse_level, c.search.mid_level);
  return local;
}

}  // namespace

FollowerApp::FollowerApp(FollowerOptions options, const std::atomic<bool>& stop)
    : o_(std::move(options)),
      stop_(stop),
      start_(std::chrono::steady_clock::now()),
      localisation_(o_.localiser),
      leader_(o_.leader_timeout),
      last_report_(start_) {
  std::signal(SIGUSR1, on_save_signal);
  if (!o_.log.empty()) {
    app::setup_step("", [&] {
      std::vector<LaserScan> scans =
          app::read_log(o_.log, o_.reader, o_.max_scans, o_.localiser.tracking.use_odometry, stop_);
      if (o_.first_scan >= scans.size()) {
        throw std::invalid_argument("--first-scan " + std::to_string(o_.first_scan) + ": " +
                                    o_.log + " has only " + std::to_string(scans.size()) +
                                    " scans" + (o_.max_scans > 0 ? " (with --max-scans)" : ""));
      }
      scans.erase(scans.begin(), scans.begin() + static_cast<std::ptrdiff_t>(o_.first_scan));
      source_ = std::make_unique<app::LogScanSource>(std::move(scans), o_.rate);
    });
  }
  app::setup_step("DDS", [&] {
    node_ = std::make_unique<dds::Node>(
        dds::NodeOptions{o_.domain, o_.profile, "esfleet-follower", o_.secure});
    map_ = std::make_unique<MapSubscriber>(*node_, o_.map_id, local_map_config(o_.localiser));
    if (!o_.scan_robot.empty()) {
      auto t = std::make_unique<app::TopicScanSource>(*node_, o_.scan_robot, o_.idle_exit,
                                                      o_.latest_only);
      topic_ = t.get();
      source_ = std::move(t);
    }
    if (o_.ros.any()) open_ros();
    if (source_) pose_writer_ = std::make_unique<dds::PoseWriter>(*node_, o_.robot_id);
    if (o_.contribute.enabled) {
      contributor_ = std::make_unique<Contributor>(*node_, o_.robot_id, o_.contribute);
    }
  });
  spdlog::info("following map '{}' on DDS domain {}", o_.map_id.empty() ? "(any)" : o_.map_id,
               o_.domain);
  if (source_) {
    spdlog::info("robot '{}': scans from {}; {} localisation; parameters: {}", o_.robot_id,
                 !o_.log.empty()          ? o_.log
                 : !o_.scan_robot.empty() ? "scan topic of '" + o_.scan_robot + "'"
                                          : "ROS topic " + o_.ros.scan_topic,
                 o_.localiser.hint ? "hinted" : "global", o_.parameter_changes);
  }
  if (contributor_) {
    const ContributorConfig& c = o_.contribute;
    spdlog::info(
        "contributing tracked scans on {} (agreement >= {}, known >= {}, every {} m or {} deg); "
        "relocalising after {} refused in a row{}",
        dds::kContributionTopic, c.send.min_agreement, c.send.min_known, c.send.min_travel,
        c.send.min_turn_deg, c.max_rejections,
        o_.contribute_pose_offset.empty()
            ? ""
            : "; TEST: pose offset " + o_.contribute_pose_offset + " added to every claim");
  }
}

// Members in reverse: the pose writer, the scan source (its reader) and the map readers go
// before the participant.
FollowerApp::~FollowerApp() {
  contributor_.reset();
  initial_pose_.reset();
  ros_pose_.reset();
  pose_writer_.reset();
  source_.reset();
  map_.reset();
  node_.reset();
}

void FollowerApp::open_ros() {
  const app::RosNames names = app::resolve_ros_names(o_.ros, o_.robot_id);
  if (!names.scan_topic.empty()) {
    auto s =
        std::make_unique<app::RosScanSource>(*node_, names, o_.ros, o_.idle_exit, o_.latest_only);
    ros_scan_ = s.get();
    source_ = std::move(s);
  }
  if (o_.ros.outputs) {
    ros_pose_ = std::make_unique<app::RosPoseOutput>(*node_, names);
    initial_pose_ =
        std::make_unique<InitialPoseInput>(*node_, names.initialpose_topic, names.map_frame);
    spdlog::info("ROS 2: pose on {} and TF {} -> {} while tracking; hints from {}",
                 names.pose_topic, names.map_frame,
                 o_.ros.odom.empty() ? names.base_frame : names.odom_frame,
                 names.initialpose_topic);
  }
}

void FollowerApp::publish_ros_pose(const LaserScan& scan, const LocaliserStep& step) {
  if (!ros_pose_ || step.state != LocaliserState::kTracking) return;
  ros_pose_->publish(
      TimedPose{scan.stamp, step.pose}, ros_scan_ != nullptr ? scan.odometry : std::nullopt,
      ros_scan_ != nullptr ? ros_scan_->mount() : Pose2{},
      app::pose_sigma(true, step.value.agreement(),
                      map_->replica().has_map() ? map_->replica().map().cell_size() : 0.05));
}

double FollowerApp::seconds_since_start() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

int FollowerApp::run() {
  while (!stop_.load() && spin()) {
  }
  if (topic_ != nullptr) {
    const app::TopicScanStats t = topic_->stats();
    spdlog::info(
        "scan topic: {} received, {} malformed, {} missing (seq gaps), {} skipped for newer "
        "ones ({} while tracking)",
        t.received, t.malformed, t.seq_gaps, t.dropped, dropped_tracking_);
  }
  if (contributor_ && contributor_->sent() > 0 && scans_ended_ && !stop_.load()) {
    settle_contributions();
  }
  if (pose_writer_) pose_writer_->wait_for_acknowledgments(std::chrono::milliseconds(500));
  const bool saved = save(stop_.load()   ? "signal"
                          : timed_out_   ? "timeout"
                          : scans_ended_ ? "scans ended"
                                         : "complete");
  if (!saved && (!o_.save_dir.empty() || !o_.trajectory_path.empty())) return app::kExitFailure;
  return timed_out_ ? app::kExitTimeout : app::kExitOk;
}

bool FollowerApp::spin() {
  map_->spin_once(std::chrono::milliseconds(source_ ? 2 : 50));
  watch_leader();
  const FollowStats& s = map_->stats();
  if (first_tile_s_ < 0 && s.tiles_applied > 0) first_tile_s_ = seconds_since_start();
  if (!warned_no_map_ && s.tiles_received == 0 && s.meta_received == 0 &&
      seconds_since_start() > kNoMapWarnS) {
    warned_no_map_ = true;
    warn_no_map();
  }
  if (complete_s_ < 0 && map_->replica().complete()) {
    complete_s_ = seconds_since_start();
    spdlog::info("map complete: {} tiles after {:.2f} s", map_->replica().map().tile_count(),
                 complete_s_);
    if (o_.exit_when_complete && !source_) return false;
  }
  if (source_ && (!o_.wait_complete || complete_s_ >= 0) && !next_scan()) return false;
  if (g_save.exchange(false)) save("SIGUSR1");
  if (std::chrono::steady_clock::now() - last_report_ > std::chrono::seconds(5)) {
    last_report_ = std::chrono::steady_clock::now();
    report();
  }
  if (o_.timeout > 0 && seconds_since_start() > o_.timeout) {
    timed_out_ = true;
    spdlog::warn("--timeout {} s reached", o_.timeout);
    return false;
  }
  return true;
}

bool FollowerApp::next_scan() {
  // One scan at a time, then DDS again: tiles keep arriving while the robot localises.
  if (!source_->ready()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    return true;
  }
  const std::uint64_t dropped_before = topic_ != nullptr ? topic_->stats().dropped : 0;
  if (initial_pose_) {
    if (const std::optional<PoseHint> hint = initial_pose_->take()) {
      spdlog::info(
          "/initialpose: localising around ({:.2f}, {:.2f}, {:.1f} deg) within {:.2f} m "
          "and {:.0f} deg",
          hint->pose.x, hint->pose.y, rad_to_deg(hint->pose.theta), hint->radius, hint->angle_deg);
      localisation_.set_hint(*hint);
    }
  }
  const bool was_tracking = localisation_.state() == LocaliserState::kTracking;
  if (auto scan = source_->poll(stop_)) {
    LocaliserStep step;
    if (!was_tracking && hold_for_map()) {
      step.state = LocaliserState::kWaitingForMap;  // a pose in part of the map could be wrong
      ++scans_held_;
    } else {
      step = localisation_.process(map_->replica(), *scan);
    }
    publish_ros_pose(*scan, step);
    if (contributor_) {
      contributor_->after_scan(*scan, step, was_tracking, map_->replica());
      if (contributor_->take_relocalise()) localisation_.reset();
    }
    if (pose_writer_) {
      pose_writer_->write(dds::pose_to_msg(o_.robot_id, {scan->stamp, step.pose},
                                           step.value.fitness, status_of(step.state)));
    }
    if (topic_ != nullptr && was_tracking) {
      dropped_tracking_ += topic_->stats().dropped - dropped_before;
      tracking_lag_ms_.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                    topic_->last_arrival_of_returned())
              .count());
    }
  } else if (source_->ended()) {
    scans_ended_ = true;
    spdlog::info("scans ended after {} scans: state {}", localisation_.stats().scans,
                 to_string(localisation_.state()));
    return false;
  }
  return true;
}

bool FollowerApp::hold_for_map() {
  const mapshare::MapReplica& replica = map_->replica();
  const std::size_t here = replica.has_map() ? replica.map().tile_count() : 0;
  if (!replica.arriving()) {
    if (holding_since_s_ >= 0) {
      spdlog::info("the final map is here ({} tiles): localising ({} scans held for it)", here,
                   scans_held_);
      holding_since_s_ = -1.0;
    }
    return false;
  }
  const double now = seconds_since_start();
  if (holding_since_s_ < 0) {
    holding_since_s_ = now;
    spdlog::info(
        "the leader's map is final but {} of its {} tiles are here: localising once it is "
        "whole (at most {:.0f} s)",
        here, replica.meta()->tile_count, kMapArrivalGraceS);
  }
  if (now - holding_since_s_ <= kMapArrivalGraceS) return true;
  if (!warned_map_grace_) {
    warned_map_grace_ = true;
    spdlog::warn("{} of the final map's {} tiles after {:.0f} s: localising in what is here", here,
                 replica.meta()->tile_count, now - holding_since_s_);
  }
  return false;
}

void FollowerApp::settle_contributions() {
  using Clock = std::chrono::steady_clock;
  const auto until = Clock::now() + std::chrono::duration<double>(o_.contribute.settle_s);
  std::optional<Clock::time_point> settled_since;  // answered and the map complete
  while (!stop_.load() && Clock::now() < until) {
    map_->spin_once(std::chrono::milliseconds(50));
    if (contributor_->take_relocalise()) localisation_.reset();
    const bool settled = contributor_->answered() && map_->replica().complete();
    if (!settled) {
      settled_since.reset();
    } else if (!settled_since) {
      settled_since = Clock::now();
    } else if (Clock::now() - *settled_since >= std::chrono::seconds(1)) {
      return;  // the tiles of the last answer had a second to arrive
    }
  }
  spdlog::warn(
      "contributions: no answer to the last of {} contributed scans, or not the "
      "complete map, within {} s",
      contributor_->sent(), o_.contribute.settle_s);
}

void FollowerApp::watch_leader() {
  const auto& meta = map_->replica().meta();
  const LeaderWatch::Event event =
      leader_.update(seconds_since_start(), map_->stats().meta_received, map_->matched_leaders(),
                     meta && !meta->complete);
  if (event == LeaderWatch::Event::kBack) {
    spdlog::info("leader back ({:.1f} s after it was reported gone)",
                 leader_.returned_at_s() - leader_.lost_at_s());
  } else if (event == LeaderWatch::Event::kGone) {
    spdlog::warn(
        "leader gone: {} (last summary {:.1f} s ago, at its scan {}); keeping the map ({} tiles) "
        "and {}",
        leader_.reason(), leader_.silence_at_loss_s(), meta ? meta->scans : 0,
        map_->replica().has_map() ? map_->replica().map().tile_count() : 0,
        source_ ? "tracking" : "waiting");
  }
}

void FollowerApp::warn_no_map() const {
  const int matched = map_->matched_leaders();
  if (matched == 0) {
    spdlog::warn(
        "no leader found in {:.0f} s on DDS domain {}{}: is a leader running with the same "
        "domain id, a compatible --profile{} and a network path to this robot? (Over shared "
        "memory, a process killed earlier on this host can also cause this: docs/faults.md, "
        "'Shared memory and killed processes'.)",
        kNoMapWarnS, o_.domain, o_.profile.empty() ? "" : " with profile " + o_.profile,
        o_.secure.empty() ? "" : " and certificates of the same CA");
  } else if (const std::uint64_t other = map_->protocol_mismatches(); other > 0) {
    spdlog::warn(
        "matched {} leader map writer(s) but in {:.0f} s received only {} sample(s) of another "
        "esfleet protocol than this follower's {} (the writers are named above): run the same "
        "esfleet release on the leader and this robot",
        matched, kNoMapWarnS, other, dds::kProtocolVersion);
  } else {
    spdlog::warn(
        "matched {} leader map writer(s) but received nothing from them in {:.0f} s: "
        "either the leader has not mapped a scan yet (is its scan source running?) or, over "
        "Fast DDS shared memory, a process killed earlier on this host left it "
        "writing to ports that no longer exist (Fast DDS 2.9; docs/faults.md, 'Shared memory "
        "and killed processes'): restart the leader, or run every program with "
        "deploy/fastdds/localhost-udp.xml",
        matched, kNoMapWarnS);
  }
}

void FollowerApp::report() const {
  const FollowStats& s = map_->stats();
  spdlog::info(
      "tiles: {} applied, {} stale, {} rejected; deltas: {} applied, {} waiting for a "
      "whole tile; map {} tiles; leaders matched {}",
      s.tiles_applied, s.tiles_stale, s.tiles_rejected, s.deltas_applied, s.deltas_needs_base,
      map_->replica().has_map() ? map_->replica().map().tile_count() : 0, map_->matched_leaders());
  if (source_) {
    const LocaliserStep& last = localisation_.last_step();
    spdlog::info("robot '{}': {} at ({:.2f}, {:.2f}, {:.1f} deg), {} scans, {} hypotheses",
                 o_.robot_id, to_string(last.state), last.pose.x, last.pose.y,
                 rad_to_deg(last.pose.theta), localisation_.stats().scans, last.hypotheses);
  }
}

nlohmann::json FollowerApp::stats_json(const char* why) const {
  const mapshare::MapReplica& replica = map_->replica();
  const FollowStats& s = map_->stats();
  const app::Summary lat = app::summarize(s.latency_ms);
  nlohmann::json j = {
      {"map_id", replica.map_id()},
      {"epoch", replica.epoch()},
      {"complete", replica.complete()},
      {"tiles", replica.has_map() ? replica.map().tile_count() : 0},
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
      {"first_tile_s", first_tile_s_},
      {"time_to_complete_s", complete_s_},
      {"saved_because", why},
      {"leader_lost", leader_.lost()},
      {"leader_returned", leader_.returned()},
      {"leader", leader_.json()},
  };
  if (source_) {
    nlohmann::json loc = localisation_.json(o_.robot_id);
    loc["scans_held_for_map"] = scans_held_;
    if (topic_ != nullptr) {
      const app::Summary lag = app::summarize(tracking_lag_ms_);
      loc["scans_dropped"] = topic_->stats().dropped;
      loc["scans_dropped_tracking"] = dropped_tracking_;
      loc["tracking_lag_ms_median"] = lag.median;
      loc["tracking_lag_ms_p95"] = lag.p95;
      loc["tracking_lag_ms_max"] = lag.max;
    }
    j["localisation"] = std::move(loc);
  }
  if (contributor_) j["contribution"] = contributor_->json();
  if (ros_scan_ != nullptr) {
    j["ros_scan"] = ros_scan_->stats().json();
    j["ros_scan"]["topic"] = o_.ros.scan_topic;
  }
  if (ros_pose_) {
    j["ros"] = {{"poses_published", ros_pose_->poses_published()},
                {"pose_and_tf_bytes", ros_pose_->bytes_written()},
                {"initialpose", initial_pose_->json()}};
  }
  return j;
}

bool FollowerApp::save(const char* why) const {
  bool ok = true;
  if (!o_.trajectory_path.empty()) {
    try {
      const std::filesystem::path parent = std::filesystem::path(o_.trajectory_path).parent_path();
      if (!parent.empty()) std::filesystem::create_directories(parent);
      write_trajectory(o_.trajectory_path, localisation_.trajectory());
    } catch (const std::exception& e) {
      spdlog::error("writing the trajectory {}: {}", o_.trajectory_path, e.what());
      ok = false;
    }
  }
  if (o_.save_dir.empty()) return ok;
  if (!map_->replica().has_map()) {
    spdlog::warn("no map received yet: only stats.json saved in {}", o_.save_dir);
    try {
      std::filesystem::create_directories(o_.save_dir);
      write_file_atomically(o_.save_dir + "/stats.json", stats_json(why).dump(2) + "\n");
    } catch (const std::exception& e) {
      spdlog::error("saving stats.json to {}: {}", o_.save_dir, e.what());
    }
    return false;
  }
  try {
    const GridMap& map = map_->replica().map();
    save_ros_map(map, o_.save_dir, "map");
    save_map_png(map, localisation_.trajectory(), o_.save_dir + "/map.png");
    write_file_atomically(o_.save_dir + "/map.digest", map_digest(map));
    write_file_atomically(o_.save_dir + "/stats.json", stats_json(why).dump(2) + "\n");
    spdlog::info("saved the map ({} tiles) to {}", map.tile_count(), o_.save_dir);
    return ok;
  } catch (const std::exception& e) {
    spdlog::error("saving the map to {}: {}", o_.save_dir, e.what());
    return false;
  }
}

}  // namespace esfleet::follower
