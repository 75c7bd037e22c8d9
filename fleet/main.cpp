// esfleet-fleet: one command for a whole simulated fleet on this host. Starts a leader that maps
// a recorded log and shares the map, the scan simulator (esfleet-sim) with N virtual robots in
// the world that log maps, and one follower per robot that localises from the simulated scans
// in the leader's map and tracks itself. Shows who is localised, the error against the
// simulator's truth and CPU/memory live; stops everything cleanly on Ctrl-C or after
// --duration, and writes a per-robot summary (--summary).

#include <fcntl.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "app/slam_run.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/core/ros_map_reader.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/reader.hpp"
#include "fleet_monitor.hpp"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using esfleet::fleet::FleetMonitor;
using esfleet::fleet::RobotReport;

static_assert(esfleet::fleet::kStatusTracking == esfleet::msg::kStatusTracking);
static_assert(esfleet::fleet::kStatusLost == esfleet::msg::kStatusLost);

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

/// One program the launcher started.
struct Child {
  std::string name;
  pid_t pid = -1;
  std::string log;
  bool exited = false;
  int exit_code = 0;         ///< exit status, or 128 + signal
  std::uint64_t ticks = 0;   ///< utime + stime at the last sample
  std::uint64_t rss_kb = 0;  ///< at the last sample
  std::uint64_t rss_kb_max = 0;
  double cpu_percent = 0.0;      ///< over the last sampling interval
  double cpu_s_at_window = 0.0;  ///< CPU seconds when the measuring window started
};

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// fork + exec with stdout and stderr to `log`, in its own process group so that the terminal's
/// Ctrl-C reaches only the launcher, which then stops the children in order.
pid_t spawn(const std::vector<std::string>& argv, const std::string& log) {
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork failed starting " + argv[0]);
  if (pid == 0) {
    setpgid(0, 0);
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
      close(fd);
    }
    execv(args[0], args.data());
    std::fprintf(stderr, "esfleet-fleet: cannot run %s: %s\n", args[0], std::strerror(errno));
    _exit(127);
  }
  return pid;
}

void reap(Child& c) {
  if (c.exited || c.pid <= 0) return;
  int status = 0;
  if (waitpid(c.pid, &status, WNOHANG) == c.pid) {
    c.exited = true;
    c.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
}

/// SIGINT, then up to `grace` for a clean exit (the programs save on SIGINT), then SIGKILL.
void stop_all(std::vector<Child*> children, std::chrono::seconds grace) {
  // Never kill(-1 or 0, ...): a child that was not started has pid -1.
  std::erase_if(children, [](const Child* c) { return c->pid <= 0; });
  for (Child* c : children) {
    reap(*c);
    if (!c->exited) kill(c->pid, SIGINT);
  }
  const auto deadline = Clock::now() + grace;
  for (Child* c : children) {
    while (!c->exited && Clock::now() < deadline) {
      reap(*c);
      if (!c->exited) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (!c->exited) {
      spdlog::warn("{} did not stop within {} s: killing it", c->name, grace.count());
      kill(c->pid, SIGKILL);
      int status = 0;
      waitpid(c->pid, &status, 0);
      c->exited = true;
      c->exit_code = 128 + SIGKILL;
    }
  }
}

void sample(Child& c, double dt_s) {
  reap(c);
  if (c.exited) {
    c.cpu_percent = 0.0;
    return;
  }
  const std::string proc = "/proc/" + std::to_string(c.pid);
  const auto ticks = esfleet::fleet::parse_proc_stat_ticks(read_text(proc + "/stat"));
  const auto rss = esfleet::fleet::parse_proc_status_rss_kb(read_text(proc + "/status"));
  static const double hz = static_cast<double>(sysconf(_SC_CLK_TCK));
  if (ticks) {
    if (dt_s > 0 && c.ticks > 0)
      c.cpu_percent = 100.0 * static_cast<double>(*ticks - c.ticks) / hz / dt_s;
    c.ticks = *ticks;
  }
  if (rss) {
    c.rss_kb = *rss;
    c.rss_kb_max = std::max(c.rss_kb_max, *rss);
  }
}

double cpu_s(const Child& c) {
  return static_cast<double>(c.ticks) / static_cast<double>(sysconf(_SC_CLK_TCK));
}
double mb(std::uint64_t kb) { return static_cast<double>(kb) / 1024.0; }

const char* status_name(std::uint8_t s) {
  switch (s) {
    case esfleet::msg::kStatusMapping:
      return "mapping";
    case esfleet::msg::kStatusWaitingForMap:
      return "waiting-map";
    case esfleet::msg::kStatusLocalising:
      return "localising";
    case esfleet::msg::kStatusTracking:
      return "tracking";
    case esfleet::msg::kStatusLost:
      return "lost";
    default:
      return "-";
  }
}

std::vector<std::string> split_args(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  std::string a;
  while (in >> a) out.push_back(a);
  return out;
}

double median_of(std::vector<double> v) { return esfleet::app::summarize(std::move(v)).median; }

}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  spdlog::set_default_logger(spdlog::stderr_color_st("fleet"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  CLI::App cli{
      "esfleet-fleet: simulates a fleet on this host. Starts esfleet-leader (maps --log and "
      "shares the map), esfleet-sim (N virtual robots in --world, scans at --rate Hz over "
      "DDS, true poses on the truth topic) and one esfleet-follower per robot (localises in the "
      "shared map with no hint, then tracks). Shows each robot's state, error against the "
      "truth and CPU live; stops all on Ctrl-C or after --duration; writes --summary.\n"
      "--world must be the map of --log made by the leader with the same parameters (so both "
      "share one frame): the defaults are the bundled MIT CSAIL log and its world "
      "(data/worlds/README.md)."};
  int robots = 4, domain = 78;
  double duration = 0.0, rate = 5.0, leader_rate = 0.0, window = 0.0;
  unsigned seed = 1;
  std::string summary_path, out_dir = "out/fleet", bin_dir;
  std::string world = "data/worlds/mit-csail/map.yaml", log = "data/mit-csail/mit-csail.clf.gz";
  std::string profile = "deploy/fastdds/localhost-shm.xml";
  std::string secure_dir;  // DDS Security: one subdirectory per identity (docs/security.md)
  std::string leader_args = "--odometry on", follower_args = "--odometry on", sim_args;
  bool live = isatty(STDOUT_FILENO) != 0, wait_map = false;
  cli.add_option("--robots", robots, "simulated robots, one follower each")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cli.add_option("--duration", duration, "stop after S seconds (0 = on Ctrl-C only)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli.add_option("--window", window,
                 "stop once every follower has tracked for S seconds (the real-time window; 0 = "
                 "no such stop)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli.add_option("--summary", summary_path,
                 "write the summary JSON here (default OUT/summary.json)");
  cli.add_option("--out", out_dir, "directory for the programs' logs, maps and stats")
      ->capture_default_str();
  cli.add_option("--domain", domain, "DDS domain id of the fleet (0-232)")
      ->check(CLI::Range(0, 232))
      ->capture_default_str();
  cli.add_option("--profile", profile, "Fast DDS XML profile for every program")
      ->capture_default_str();
  cli.add_option("--secure", secure_dir,
                 "DDS Security for every program: DIR/<id> per identity (leader, robot-1..N, "
                 "sim, and monitor for this launcher), as deploy/security/make-fleet-certs.sh "
                 "makes them (docs/security.md)");
  cli.add_option("--world", world, "world map for the simulator (ROS map YAML)")
      ->capture_default_str();
  cli.add_option("--log", log, "CARMEN log the leader maps (its map's frame is the world's)")
      ->capture_default_str();
  cli.add_option("--rate", rate, "laser scans per second per robot")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cli.add_option("--leader-rate", leader_rate,
                 "leader's replay speed of --log (0 = as fast as it maps, 1 = recorded speed)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli.add_option("--seed", seed, "seed of the simulator (robot k's follower gets seed + k)")
      ->capture_default_str();
  cli.add_option("--leader-args", leader_args, "extra esfleet-leader flags (one string)")
      ->capture_default_str();
  cli.add_option("--follower-args", follower_args, "extra esfleet-follower flags (one string)")
      ->capture_default_str();
  cli.add_option("--sim-args", sim_args, "extra esfleet-sim flags (one string)");
  cli.add_flag("--wait-map", wait_map,
               "start the simulator and followers only once the leader's map is complete (the "
               "fleet joins a mapped building; scale measurements). Default: all at once, the "
               "followers localise while the map grows");
  cli.add_option("--bin-dir", bin_dir,
                 "where the esfleet programs are (default: next to this one)");
  cli.add_option("--live", live, "redraw a status table every second (default: on a terminal)");
  CLI11_PARSE(cli, argc, argv);

  if (bin_dir.empty()) bin_dir = fs::canonical("/proc/self/exe").parent_path().string();
  if (summary_path.empty()) summary_path = out_dir + "/summary.json";
  for (const auto& [flag, path] :
       {std::pair{"--world", world}, std::pair{"--log", log}, std::pair{"--profile", profile}}) {
    if (!fs::is_regular_file(path)) {
      spdlog::error("{} {}: no such file", flag, path);
      return 2;
    }
  }
  // --secure: DIR/<id> for every identity the fleet uses (the Node checks the files in each).
  auto secure_for = [&](const std::string& id) {
    return secure_dir.empty() ? std::string() : (fs::path(secure_dir) / id).string();
  };
  if (!secure_dir.empty()) {
    std::vector<std::string> ids = {"leader", "sim", "monitor"};
    for (int k = 1; k <= robots; ++k) ids.push_back("robot-" + std::to_string(k));
    for (const auto& id : ids) {
      if (!fs::is_directory(secure_for(id))) {
        spdlog::error("--secure {}: no directory {} (make-fleet-certs.sh {} ... {})", secure_dir,
                      secure_for(id), secure_dir, id);
        return 2;
      }
    }
  }
  for (const char* prog : {"esfleet-leader", "esfleet-follower", "esfleet-sim"}) {
    if (access((bin_dir + "/" + prog).c_str(), X_OK) != 0) {
      spdlog::error("--bin-dir {}: no executable {}", bin_dir, prog);
      return 2;
    }
  }
  try {
    (void)load_ros_map(world);  // a clear error here rather than in the simulator's log
    fs::create_directories(out_dir);
    const fs::path sp = fs::path(summary_path).parent_path();
    if (!sp.empty()) fs::create_directories(sp);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 2;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGPIPE, SIG_IGN);

  // The launcher's own DDS reader: what the robots say and where the simulator put them. The
  // callbacks only queue (docs/style.md rule 4).
  std::mutex mutex;
  std::vector<fleet::PoseSample> poses;
  std::vector<fleet::TruthSample> truths;
  std::optional<msg::MapMeta> meta;
  std::unique_ptr<dds::Node> node;
  std::unique_ptr<dds::PoseReader> pose_reader;
  std::unique_ptr<dds::TruthReader> truth_reader;
  std::unique_ptr<dds::MetaReader> meta_reader;
  try {
    node = std::make_unique<dds::Node>(
        dds::NodeOptions{domain, profile, "esfleet-fleet", secure_for("monitor")});
    // Every robot's partition (pose and truth writers publish in their robot's / "sim").
    pose_reader = std::make_unique<dds::PoseReader>(
        *node,
        [&](const msg::RobotPose& m, const dds::SampleMeta&) {
          std::lock_guard lock(mutex);
          poses.push_back(
              {m.robot_id().to_string(), m.stamp(), m.x(), m.y(), m.theta(), m.status()});
        },
        dds::kAllPartitions);
    truth_reader = std::make_unique<dds::TruthReader>(
        *node,
        [&](const msg::TruthPose& m, const dds::SampleMeta&) {
          std::lock_guard lock(mutex);
          truths.push_back({m.robot_id().to_string(), m.stamp(), m.x(), m.y(), m.theta()});
        },
        dds::kAllPartitions);
    meta_reader = std::make_unique<dds::MetaReader>(
        *node, [&](const msg::MapMeta& m, const dds::SampleMeta&) {
          std::lock_guard lock(mutex);
          meta = m;
        });
  } catch (const std::exception& e) {
    spdlog::error("DDS: {}", e.what());
    return 2;
  }

  const std::vector<std::string> common_dds_flags = {"--domain", std::to_string(domain),
                                                     "--profile", profile};
  // The DDS flags of the child with identity `id`: --secure DIR/<id> when secure.
  auto dds_flags = [&](const std::string& id) {
    std::vector<std::string> flags = common_dds_flags;
    if (!secure_dir.empty()) flags.insert(flags.end(), {"--secure", secure_for(id)});
    return flags;
  };
  auto with = [](std::vector<std::string> a, const std::vector<std::string>& b) {
    a.insert(a.end(), b.begin(), b.end());
    return a;
  };
  FleetMonitor monitor;
  Child leader, sim;
  leader.name = "leader";
  sim.name = "sim";
  std::vector<Child> followers(static_cast<std::size_t>(robots));
  // Named and registered up front: the status table and the summary cover every robot, also
  // when the run stops before the followers were started.
  for (int k = 1; k <= robots; ++k) {
    Child& f = followers[static_cast<std::size_t>(k - 1)];
    f.name = "robot-" + std::to_string(k);
    f.log = out_dir + "/" + f.name + ".log";
    monitor.add_robot(f.name);
  }
  std::string failure;  ///< why the run ended early; empty = it ran as asked
  const auto start = Clock::now();
  auto now_s = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
  try {
    leader.log = out_dir + "/leader.log";
    leader.pid = spawn(
        with(with({bin_dir + "/esfleet-leader", "--log", log, "--rate", std::to_string(leader_rate),
                   "--linger", "-1", "--out", out_dir + "/leader"},
                  dds_flags("leader")),
             split_args(leader_args)),
        leader.log);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    failure = e.what();
    g_stop.store(true);
  }
  if (wait_map) {
    spdlog::info("waiting for the leader's map to be complete (--wait-map)");
    auto last = Clock::now();
    while (!g_stop.load()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
      std::optional<msg::MapMeta> m;
      {
        std::lock_guard lock(mutex);
        m = meta;
      }
      if (m && m->complete()) {
        spdlog::info("map complete after {:.1f} s: {} tiles, {} scans", now_s(), m->tile_count(),
                     m->scans());
        break;
      }
      reap(leader);
      if (leader.exited) {
        spdlog::error("the leader exited (code {}) before its map was complete; see {}",
                      leader.exit_code, leader.log);
        g_stop.store(true);
      }
      if (duration > 0 && now_s() >= duration) {
        spdlog::error("--duration {} s passed before the leader's map was complete", duration);
        g_stop.store(true);
      }
      if (Clock::now() - last > std::chrono::seconds(5)) {
        last = Clock::now();
        spdlog::info("leader mapping: {} scans, {} tiles", m ? m->scans() : 0,
                     m ? m->tile_count() : 0);
      }
    }
  }
  const double followers_start_s = now_s();
  try {
    if (g_stop.load()) throw std::runtime_error("stopped before the followers started");
    for (int k = 1; k <= robots; ++k) {
      Child& f = followers[static_cast<std::size_t>(k - 1)];
      f.pid = spawn(
          with(with({bin_dir + "/esfleet-follower", "--scan-topic", f.name, "--robot-id", f.name,
                     "--seed", std::to_string(seed + k), "--save-map", out_dir + "/" + f.name,
                     "--trajectory", out_dir + "/" + f.name + "/trajectory.txt"},
                    dds_flags(f.name)),
               split_args(follower_args)),
          f.log);
    }
    sim.log = out_dir + "/sim.log";
    sim.pid = spawn(
        with(with({bin_dir + "/esfleet-sim", "--world", world, "--robots", std::to_string(robots),
                   "--rate", std::to_string(rate), "--seed", std::to_string(seed)},
                  dds_flags("sim")),
             split_args(sim_args)),
        sim.log);
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    failure = e.what();
    g_stop.store(true);
  }
  spdlog::info("fleet of {} robots on domain {} ({}); logs and maps in {}{}", robots, domain,
               profile, out_dir,
               duration > 0 ? fmt::format("; stopping after {} s", duration) : "; Ctrl-C stops");

  std::vector<Child*> all = {&sim};
  for (auto& f : followers) all.push_back(&f);
  all.push_back(&leader);

  std::map<std::string, std::size_t> poses_at_last_draw;
  auto draw = [&](double dt) {
    std::ostringstream o;
    std::optional<msg::MapMeta> m;
    {
      std::lock_guard lock(mutex);
      m = meta;
    }
    o << fmt::format("esfleet fleet: {} robots, domain {}, {:.0f} s{}\n", robots, domain, now_s(),
                     duration > 0 ? fmt::format(" of {:.0f}", duration) : "");
    o << fmt::format("  leader  {:>4.0f}% CPU {:>5.0f} MB  map: {}\n", leader.cpu_percent,
                     mb(leader.rss_kb),
                     m ? fmt::format("{} tiles, {} scans{}", m->tile_count(), m->scans(),
                                     m->complete() ? ", complete" : "")
                       : std::string("none yet"));
    o << fmt::format("  sim     {:>4.0f}% CPU {:>5.0f} MB\n", sim.cpu_percent, mb(sim.rss_kb));
    o << fmt::format("  {:<10} {:<11} {:>9} {:>7} {:>7} {:>6} {:>6} {:>7}\n", "robot", "state",
                     "localised", "err m", "med m", "CPU %", "MB", "poses/s");
    for (const Child& f : followers) {
      const RobotReport& r = monitor.robots().at(f.name);
      const std::size_t before = poses_at_last_draw[f.name];
      poses_at_last_draw[f.name] = r.poses;
      o << fmt::format(
          "  {:<10} {:<11} {:>9} {:>7} {:>7} {:>6.0f} {:>6.0f} {:>7.1f}{}\n", f.name,
          f.exited ? "EXITED" : status_name(r.status),
          r.localised_s ? fmt::format("{:.1f} s", *r.localised_s - followers_start_s) : "-",
          r.last_error_xy_m ? fmt::format("{:.2f}", *r.last_error_xy_m) : "-",
          r.error_xy_m.empty() ? "-" : fmt::format("{:.2f}", median_of(r.error_xy_m)),
          f.cpu_percent, mb(f.rss_kb), dt > 0 ? static_cast<double>(r.poses - before) / dt : 0.0,
          r.wrong_declarations > 0 ? "  WRONG POSE DECLARED" : "");
    }
    if (live) {
      std::cout << "\x1b[H\x1b[2J" << o.str() << std::flush;
    } else {
      std::cout << o.str() << std::flush;
    }
  };

  double window_start_s = -1.0;
  auto last_sample = Clock::now();
  auto last_draw = Clock::now();
  while (!g_stop.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    std::vector<fleet::PoseSample> p;
    std::vector<fleet::TruthSample> t;
    {
      std::lock_guard lock(mutex);
      p.swap(poses);
      t.swap(truths);
    }
    // Truth first: the pose of a scan is published after the scan (and its truth) went out.
    for (const auto& s : t) monitor.on_truth(s);
    for (const auto& s : p) monitor.on_pose(s, now_s());
    const double dt = std::chrono::duration<double>(Clock::now() - last_sample).count();
    if (dt >= 1.0) {
      last_sample = Clock::now();
      for (Child* c : all) sample(*c, dt);
      // The measuring window of real-time tracking starts once every follower tracks: before,
      // global searches of other robots compete for the CPU.
      if (!monitor.window_started() && monitor.all_tracking()) {
        monitor.start_window();
        window_start_s = now_s();
        for (Child* c : all) c->cpu_s_at_window = cpu_s(*c);
        spdlog::info("all {} followers tracking after {:.1f} s: real-time window starts", robots,
                     window_start_s);
      }
      for (Child* c : all) {
        if (c->exited && failure.empty()) {
          failure = fmt::format("{} exited early (code {}); see {}", c->name, c->exit_code, c->log);
        }
      }
      if (!failure.empty()) {
        spdlog::error("{}", failure);
        break;
      }
    }
    const double ddt = std::chrono::duration<double>(Clock::now() - last_draw).count();
    if (ddt >= (live ? 1.0 : 5.0)) {
      last_draw = Clock::now();
      draw(ddt);
    }
    if (duration > 0 && now_s() >= duration) break;
    if (window > 0 && window_start_s >= 0 && now_s() - window_start_s >= window) break;
  }
  const double end_s = now_s();
  const double window_s = window_start_s >= 0 ? end_s - window_start_s : 0.0;
  for (Child* c : all) sample(*c, 0.0);
  spdlog::info("stopping: simulator, followers (they save their maps), leader");
  stop_all({&sim}, std::chrono::seconds(10));
  std::vector<Child*> fs_;
  for (auto& f : followers) fs_.push_back(&f);
  stop_all(fs_, std::chrono::seconds(20));
  stop_all({&leader}, std::chrono::seconds(30));
  pose_reader.reset();
  truth_reader.reset();
  meta_reader.reset();
  node.reset();

  // Summary: per robot what the launcher saw plus what the follower wrote in its stats.json.
  const double period_ms = 1000.0 / rate;
  nlohmann::json jf = nlohmann::json::array();
  int localised = 0, realtime = 0, wrong = 0;
  for (const Child& f : followers) {
    const RobotReport& r = monitor.robots().at(f.name);
    nlohmann::json stats;
    try {
      stats = nlohmann::json::parse(read_text(out_dir + "/" + f.name + "/stats.json"));
    } catch (const std::exception&) {
      stats = nlohmann::json::object();
    }
    const nlohmann::json loc = stats.value("localisation", nlohmann::json::object());
    const std::size_t tracked = loc.value("tracked_scans", std::size_t{0});
    const std::uint64_t dropped = loc.value("scans_dropped_tracking", std::uint64_t{0});
    const double lag_p95 = loc.value("tracking_lag_ms_p95", 0.0);
    (void)tracked;
    // Real time: in the window where all track, (almost) every scan the simulator sent got a
    // pose (>= 98 %), and 95 % of them within one scan period of the scan's arrival.
    const double processed = r.window_truth > 0 ? static_cast<double>(r.window_tracking_poses) /
                                                      static_cast<double>(r.window_truth)
                                                : 0.0;
    const bool rt = window_s >= 10.0 && processed >= 0.98 && lag_p95 < period_ms;
    const app::Summary exy = app::summarize(r.error_xy_m);
    std::vector<double> eth_deg;
    for (double e : r.error_theta_rad) eth_deg.push_back(e * 180.0 / M_PI);
    const app::Summary eth = app::summarize(eth_deg);
    nlohmann::json j = {
        {"robot_id", f.name},
        {"final_state", status_name(r.status)},
        {"localised", r.localised_s.has_value()},
        {"time_to_localise_s", r.localised_s ? *r.localised_s - followers_start_s : -1.0},
        {"first_pose_error_m", r.first_error_xy_m ? *r.first_error_xy_m : -1.0},
        {"first_pose_error_deg",
         r.first_error_theta_rad ? *r.first_error_theta_rad * 180.0 / M_PI : -1.0},
        {"declarations", r.declarations},
        {"wrong_declarations", r.wrong_declarations},
        {"lost_events", r.lost_events},
        {"tracking_poses_scored", r.matched},
        {"tracking_error_m_median", exy.median},
        {"tracking_error_m_p95", exy.p95},
        {"tracking_error_m_max", exy.max},
        {"tracking_error_deg_median", eth.median},
        {"tracking_error_deg_p95", eth.p95},
        {"cpu_s", cpu_s(f)},
        {"cpu_percent_window",
         window_s > 1.0 ? 100.0 * (cpu_s(f) - f.cpu_s_at_window) / window_s : -1.0},
        {"window_scans", r.window_truth},
        {"window_poses", r.window_tracking_poses},
        {"window_processed", processed},
        {"rss_mb_max", mb(f.rss_kb_max)},
        {"bytes_received", stats.value("bytes_received", std::uint64_t{0})},
        {"map_tiles", stats.value("tiles", std::uint64_t{0})},
        {"scans_processed", loc.value("scans", std::size_t{0})},
        {"scans_dropped", loc.value("scans_dropped", std::uint64_t{0})},
        {"scans_dropped_tracking", dropped},
        {"tracking_lag_ms_median", loc.value("tracking_lag_ms_median", 0.0)},
        {"tracking_lag_ms_p95", lag_p95},
        {"tracking_cpu_ms_median", loc.value("tracking_cpu_ms_median", 0.0)},
        {"realtime", rt},
        {"started", f.pid > 0},
        {"exit_code", f.pid > 0 ? f.exit_code : -1},
    };
    localised += r.localised_s ? 1 : 0;
    realtime += rt ? 1 : 0;
    wrong += r.wrong_declarations > 0 ? 1 : 0;
    jf.push_back(j);
  }
  const nlohmann::json summary = {
      {"robots", robots},
      {"duration_s", end_s},
      {"followers_started_s", followers_start_s},
      {"all_tracking_s", window_start_s >= 0 ? window_start_s - followers_start_s : -1.0},
      {"window_s", window_s},
      {"rate_hz", rate},
      {"domain", domain},
      {"profile", profile},
      {"seed", seed},
      {"cores", std::thread::hardware_concurrency()},
      {"localised", localised},
      {"realtime", realtime},
      {"robots_with_wrong_pose", wrong},
      {"all_localised", localised == robots},
      {"all_realtime", realtime == robots},
      {"failure", failure},
      {"leader",
       {{"cpu_s", cpu_s(leader)},
        {"rss_mb_max", mb(leader.rss_kb_max)},
        {"cpu_percent_window",
         window_s > 1.0 ? 100.0 * (cpu_s(leader) - leader.cpu_s_at_window) / window_s : -1.0},
        {"exit_code", leader.exit_code}}},
      {"sim",
       {{"cpu_s", cpu_s(sim)},
        {"rss_mb_max", mb(sim.rss_kb_max)},
        {"cpu_percent_window",
         window_s > 1.0 ? 100.0 * (cpu_s(sim) - sim.cpu_s_at_window) / window_s : -1.0},
        {"exit_code", sim.exit_code}}},
      {"followers", jf},
  };
  try {
    write_file_atomically(summary_path, summary.dump(2) + "\n");
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  std::cout << fmt::format(
      "fleet of {}: {} localised, {} in real time, {} with a wrong pose; summary {}\n", robots,
      localised, realtime, wrong, summary_path);
  return failure.empty() ? 0 : 1;
}
