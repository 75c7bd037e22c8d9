#include "fleet_app.hpp"

#include <spdlog/spdlog.h>

#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <iostream>
#include <thread>

#include "app/program.hpp"
#include "child_args.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/core/ros_map_reader.hpp"

namespace esfleet::fleet {

namespace fs = std::filesystem;
using app::UsageError;

static_assert(kStatusMapping == msg::kStatusMapping);
static_assert(kStatusWaitingForMap == msg::kStatusWaitingForMap);
static_assert(kStatusLocalising == msg::kStatusLocalising);
static_assert(kStatusTracking == msg::kStatusTracking);
static_assert(kStatusLost == msg::kStatusLost);

FleetApp::FleetApp(FleetOptions options, const std::atomic<bool>& stop)
    : o_(std::move(options)), stop_(stop), bin_dir_(o_.bin_directory()) {
  try {
    (void)load_ros_map(o_.world);  // a clear error here rather than in the simulator's log
  } catch (const std::exception& e) {
    throw UsageError(app::name_flag("--world", o_.world, e.what()));
  }
  try {
    fs::create_directories(o_.out);
  } catch (const std::exception& e) {
    throw UsageError(app::name_flag("--out", o_.out, e.what()));
  }
  try {
    const fs::path sp = fs::path(o_.summary_path()).parent_path();
    if (!sp.empty()) fs::create_directories(sp);
  } catch (const std::exception& e) {
    throw UsageError(app::name_flag("--summary", o_.summary_path(), e.what()));
  }
  std::signal(SIGPIPE, SIG_IGN);

  // The launcher's own DDS readers: what the robots say and where the simulator put them, from
  // every robot's partition (pose and truth writers publish in their robot's / "sim"). The
  // callbacks only queue.
  try {
    node_ = std::make_unique<dds::Node>(
        dds::NodeOptions{o_.domain, o_.profile, "esfleet-fleet", o_.secure_dir_for("monitor")});
  } catch (const std::exception& e) {
    throw UsageError(fmt::format("DDS participant on domain {}: {}", o_.domain, e.what()));
  }
  try {
    pose_reader_ = std::make_unique<dds::PoseReader>(
        *node_,
        [this](const msg::RobotPose& m, const dds::SampleMeta&) {
          std::lock_guard lock(mutex_);
          poses_.push_back(
              {m.robot_id().to_string(), m.stamp(), m.x(), m.y(), m.theta(), m.status()});
        },
        dds::kAllPartitions);
    truth_reader_ = std::make_unique<dds::TruthReader>(
        *node_,
        [this](const msg::TruthPose& m, const dds::SampleMeta&) {
          std::lock_guard lock(mutex_);
          truths_.push_back({m.robot_id().to_string(), m.stamp(), m.x(), m.y(), m.theta()});
        },
        dds::kAllPartitions);
    meta_reader_ = std::make_unique<dds::MetaReader>(
        *node_, [this](const msg::MapMeta& m, const dds::SampleMeta&) {
          std::lock_guard lock(mutex_);
          const std::uint32_t at_complete = map_ && map_->tiles_when_complete > 0
                                                ? map_->tiles_when_complete
                                                : (m.complete() ? m.tile_count() : 0);
          map_ = MapProgress{m.tile_count(), m.scans(), m.complete(), at_complete};
        });
  } catch (const std::exception& e) {
    throw UsageError(fmt::format("DDS readers on domain {}: {}", o_.domain, e.what()));
  }

  // Named and registered up front: the status table and the summary cover every robot, also
  // when the run stops before the followers were started.
  leader_.name = "leader";
  leader_.log = o_.out + "/leader.log";
  sim_.name = "sim";
  sim_.log = o_.out + "/sim.log";
  view_.name = "view";
  view_.log = o_.out + "/view.log";
  followers_.resize(static_cast<std::size_t>(o_.robots));
  for (int k = 1; k <= o_.robots; ++k) {
    ChildProcess& f = followers_[static_cast<std::size_t>(k - 1)];
    f.name = robot_name(k);
    f.log = o_.out + "/" + f.name + ".log";
    monitor_.add_robot(f.name);
  }
}

FleetApp::~FleetApp() {
  stop_children();  // only those still running: after run() there are none
  meta_reader_.reset();
  truth_reader_.reset();
  pose_reader_.reset();
  node_.reset();
}

int FleetApp::run() {
  start_ = Clock::now();
  start_leader();
  if (o_.wait_map) wait_for_map();
  followers_start_s_ = now_s();
  start_robots();
  spdlog::info(
      "fleet of {} robots on domain {} ({}); logs and maps in {}{}", o_.robots, o_.domain,
      o_.profile, o_.out,
      o_.duration > 0 ? fmt::format("; stopping after {} s", o_.duration) : "; Ctrl-C stops");
  std::cout << StatusTable::legend(Tolerance{}) << std::flush;
  watch();
  const FleetTimes times{now_s(), followers_start_s_, window_start_s_};
  for (ChildProcess* c : children()) sample(*c, 0.0);
  if (!o_.live) draw(now_s() - followers_start_s_);  // not a terminal: the table once, at the end
  spdlog::info("stopping: simulator, followers (they save their maps), leader");
  stop_children();
  // Nothing more to hear: the summary works from what the monitor has.
  meta_reader_.reset();
  truth_reader_.reset();
  pose_reader_.reset();
  node_.reset();
  return finish(times);
}

void FleetApp::fail(const std::string& why) {
  spdlog::error("{}", why);
  failure_ = why;
  abort_ = true;
}

std::optional<MapProgress> FleetApp::map_progress() const {
  std::lock_guard lock(mutex_);
  return map_;
}

std::vector<ChildProcess*> FleetApp::children() {
  std::vector<ChildProcess*> all = {&sim_};
  for (auto& f : followers_) all.push_back(&f);
  all.push_back(&leader_);
  return all;
}

void FleetApp::start_leader() {
  try {
    start(leader_, on_host(o_, kLeaderHost, leader_argv(o_, bin_dir_)));
    if (o_.view_port >= 0) {
      start(view_, view_argv(o_, bin_dir_));
      char host[256] = "localhost";
      gethostname(host, sizeof host - 1);
      spdlog::info("the fleet in a browser: http://{}:{}/ (esfleet-view, log {})", host,
                   o_.view_port, view_.log);
    }
  } catch (const std::exception& e) {
    fail(e.what());
  }
}

void FleetApp::wait_for_map() {
  spdlog::info("waiting for the leader's map to be complete (--wait-map)");
  auto last = Clock::now();
  while (!stopping()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const std::optional<MapProgress> m = map_progress();
    if (m && m->complete) {
      spdlog::info("map complete after {:.1f} s: {} tiles, {} scans", now_s(), m->tiles, m->scans);
      break;
    }
    reap(leader_);
    // Either way the robots are not started, which makes the run's failure.
    if (leader_.exited) {
      spdlog::error("the leader exited (code {}) before its map was complete; see {}",
                    leader_.exit_code, leader_.log);
      abort_ = true;
    }
    if (o_.duration > 0 && now_s() >= o_.duration) {
      spdlog::error("--duration {} s passed before the leader's map was complete", o_.duration);
      abort_ = true;
    }
    if (Clock::now() - last > std::chrono::seconds(5)) {
      last = Clock::now();
      spdlog::info("leader mapping: {} scans, {} tiles", m ? m->scans : 0, m ? m->tiles : 0);
    }
  }
}

void FleetApp::start_robots() {
  try {
    if (stopping()) throw std::runtime_error("stopped before the followers started");
    for (int k = 1; k <= o_.robots; ++k) {
      start(followers_[static_cast<std::size_t>(k - 1)],
            on_host(o_, follower_host(k), follower_argv(o_, bin_dir_, k)));
    }
    start(sim_, on_host(o_, kSimHost, sim_argv(o_, bin_dir_)));
  } catch (const std::exception& e) {
    fail(e.what());
  }
}

void FleetApp::watch() {
  auto last_sample = Clock::now();
  auto last_draw = Clock::now();
  while (!stopping()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::vector<PoseSample> p;
    std::vector<TruthSample> t;
    {
      std::lock_guard lock(mutex_);
      p.swap(poses_);
      t.swap(truths_);
    }
    // Truth first: the pose of a scan is published after the scan (and its truth) went out.
    for (const auto& s : t) monitor_.on_truth(s);
    for (const auto& s : p) monitor_.on_pose(s, now_s());
    const double dt = std::chrono::duration<double>(Clock::now() - last_sample).count();
    if (dt >= 1.0) {
      last_sample = Clock::now();
      if (!check_children(dt)) break;
    }
    const double ddt = std::chrono::duration<double>(Clock::now() - last_draw).count();
    if (o_.live && ddt >= 1.0) {
      last_draw = Clock::now();
      draw(ddt);
    }
    if (o_.duration > 0 && now_s() >= o_.duration) break;
    if (o_.window > 0 && window_start_s_ >= 0 && now_s() - window_start_s_ >= o_.window) break;
  }
}

bool FleetApp::check_children(double dt_s) {
  for (ChildProcess* c : children()) sample(*c, dt_s);
  // The measuring window of real-time tracking starts once every follower tracks: before,
  // global searches of other robots compete for the CPU.
  if (!monitor_.window_started() && monitor_.all_tracking()) {
    monitor_.start_window();
    window_start_s_ = now_s();
    for (ChildProcess* c : children()) c->cpu_s_at_window = c->cpu_s();
    spdlog::info("all {} followers tracking after {:.1f} s: real-time window starts", o_.robots,
                 window_start_s_);
  }
  if (view_.started()) {
    sample(view_, dt_s);
    // The view only watches: when it ends (its port taken, say) the fleet goes on without it.
    if (view_.exited && !view_gone_logged_) {
      spdlog::warn("esfleet-view exited (code {}): the fleet goes on without it; see {}",
                   view_.exit_code, view_.log);
      view_gone_logged_ = true;
    }
  }
  // A follower that died (crashed, killed) is started again, as its systemd unit would: it
  // rejoins, gets the map and localises anew. The simulator is not restarted.
  for (std::size_t i = 0; i < followers_.size() && !stopping(); ++i) {
    ChildProcess& f = followers_[i];
    if (!f.exited || f.restarts >= o_.max_restarts) continue;
    spdlog::warn("{} died (code {}); restarting it ({} of at most {}); its log so far: {}.{}",
                 f.name, f.exit_code, f.restarts + 1, o_.max_restarts, f.log, f.restarts + 1);
    try {
      const int k = static_cast<int>(i) + 1;
      restart(f, on_host(o_, follower_host(k), follower_argv(o_, bin_dir_, k)));
    } catch (const std::exception& e) {
      failure_ = fmt::format("cannot restart {}: {}", f.name, e.what());
    }
  }
  restart_leader();
  for (ChildProcess* c : children()) {
    if (c->exited && failure_.empty()) {
      failure_ = fmt::format("{} exited early (code {}); see {}", c->name, c->exit_code, c->log);
    }
  }
  if (!failure_.empty()) {
    spdlog::error("{}", failure_);
    return false;
  }
  return true;
}

void FleetApp::restart_leader() {
  if (stopping() || !leader_.exited || leader_.restarts >= o_.max_leader_restarts) return;
  // As the leader's systemd unit would: the same map continues from its last checkpoint (the
  // followers keep theirs: same map id and epoch), or a new map when it left none.
  const bool resume = fs::exists(o_.out + "/leader/checkpoint");
  spdlog::warn(
      "the leader died (code {}); restarting it ({} of at most {}{}); its log so far: {}.{}",
      leader_.exit_code, leader_.restarts + 1, o_.max_leader_restarts,
      resume ? ", --resume from its checkpoint" : ", no checkpoint: a new map", leader_.log,
      leader_.restarts + 1);
  try {
    restart(leader_, on_host(o_, kLeaderHost, leader_argv(o_, bin_dir_, resume)));
  } catch (const std::exception& e) {
    failure_ = fmt::format("cannot restart the leader: {}", e.what());
  }
}

void FleetApp::draw(double dt_s) {
  const StatusHeader header{.robots = o_.robots,
                            .domain = o_.domain,
                            .now_s = now_s(),
                            .duration_s = o_.duration,
                            .followers_start_s = followers_start_s_,
                            .map = map_progress()};
  const std::string table = table_.render(header, leader_, sim_, followers_, monitor_, dt_s);
  std::cout << (o_.live ? "\x1b[H\x1b[2J" : "") << table << std::flush;
}

void FleetApp::stop_children() {
  stop_all({&sim_, &view_}, std::chrono::seconds(10));
  std::vector<ChildProcess*> followers;
  for (auto& f : followers_) followers.push_back(&f);
  stop_all(followers, std::chrono::seconds(20));
  stop_all({&leader_}, std::chrono::seconds(30));
}

int FleetApp::finish(const FleetTimes& times) {
  // Per robot what the launcher saw plus what the follower wrote in its stats.json.
  std::vector<nlohmann::json> stats;
  for (const ChildProcess& f : followers_) {
    stats.push_back(read_stats_json(o_.out + "/" + f.name + "/stats.json"));
  }
  FleetSummary s = build_summary(o_, times, failure_, leader_, sim_, followers_, monitor_, stats);
  // The shared map: tiles when the leader's own mapping ended and at the end (with
  // --contribute the followers' scans grow it), and what the leader did with contributions.
  if (const std::optional<MapProgress> m = map_progress()) {
    s.json["map"] = {{"tiles", m->tiles},
                     {"tiles_when_leader_done", m->tiles_when_complete},
                     {"leader_scans", m->scans}};
  }
  const nlohmann::json leader_stats = read_stats_json(o_.out + "/leader/stats.json");
  if (leader_stats.contains("contributions")) {
    s.json["contributions"] = leader_stats["contributions"];
  }
  try {
    write_file_atomically(o_.summary_path(), s.json.dump(2) + "\n");
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return app::kExitFailure;
  }
  std::cout << summary_line(s, o_.robots, o_.summary_path()) << "\n";
  return failure_.empty() ? app::kExitOk : app::kExitFailure;
}

}  // namespace esfleet::fleet
