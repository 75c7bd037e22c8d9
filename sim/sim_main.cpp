// esfleet-sim: a fleet scan simulator. Loads a world map (ROS map_server YAML + image), drives N
// virtual robots through its free space, ray-casts their laser scans and publishes each robot's
// scans (with noisy odometry) on esfleet/robots/scan and its true pose on esfleet/sim/truth, in
// real time at the sensor rate; or writes CARMEN logs and true trajectories (--out-log), also
// as fast as possible without DDS (--offline). The model is in docs/sim.md.
//
// Exit codes: 0 done (--duration reached), 2 usage error, bad world file or DDS refused to
// start, 130 stopped by SIGINT/SIGTERM (outputs are complete up to the last tick either way).

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "app/dds_flags.hpp"
#include "esfleet/core/clock.hpp"
#include "esfleet/dds/map_convert.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/writer.hpp"
#include "esfleet/sim/fleet.hpp"
#include "esfleet/sim/log_writer.hpp"
#include "esfleet/sim/world.hpp"

namespace {

using Clock = std::chrono::steady_clock;

constexpr int kExitError = 2;
constexpr int kExitInterrupted = 130;
constexpr std::chrono::milliseconds kPoll{100};
constexpr std::chrono::seconds kProgressPeriod{5};
constexpr std::chrono::seconds kFinalAckTimeout{3};

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }

struct SimOptions {
  std::string world;                ///< ROS map_server YAML of the world
  esfleet::sim::FleetConfig fleet;  ///< robots, motion, sensor, odometry
  double duration = 0.0;            ///< seconds of sim time; 0 = until SIGINT/SIGTERM
  int domain = 0;                   ///< DDS domain id
  std::string profile;              ///< Fast DDS XML profile; empty = Fast DDS defaults
  std::string secure;               ///< DDS Security directory (docs/security.md); empty = off
  std::string out_log;              ///< directory for <id>.log and <id>.truth; empty = none
  bool offline = false;             ///< no DDS, as fast as possible (needs out_log, duration)
  int wait_subscribers = 0;         ///< before the first tick, wait for this many scan readers
                                    ///< (summed over the robots' writers)
  double wait_timeout = 30.0;       ///< ... at most this many seconds

  /// Throws std::invalid_argument naming the flag.
  void validate() const {
    fleet.validate();
    if (!(duration >= 0.0 && duration <= 1e7)) {
      throw std::invalid_argument("--duration must be in [0, 1e7]");
    }
    if (domain < 0 || domain > esfleet::dds::kMaxDomain) {
      throw std::invalid_argument("--domain must be in [0, 232]");
    }
    if (offline && out_log.empty()) throw std::invalid_argument("--offline needs --out-log DIR");
    if (offline && duration <= 0.0) throw std::invalid_argument("--offline needs --duration > 0");
    if (wait_subscribers < 0) throw std::invalid_argument("--wait-subscribers must be >= 0");
    if (!(wait_timeout >= 0.0)) throw std::invalid_argument("--wait-timeout must be >= 0");
  }
};

/// User + system CPU of the whole process (DDS threads included), seconds.
double process_cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  auto secs = [](const timeval& tv) {
    return static_cast<double>(tv.tv_sec) + static_cast<double>(tv.tv_usec) * 1e-6;
  };
  return secs(ru.ru_utime) + secs(ru.ru_stime);
}

/// The DDS side: one participant, one scan writer per robot (in the robot's partition, so a
/// reader of one robot gets only its scans; docs/security.md) and the truth writer (partition
/// "sim").
struct Publisher {
  std::unique_ptr<esfleet::dds::Node> node;
  std::vector<std::unique_ptr<esfleet::dds::ScanWriter>> scans;  ///< per robot, fleet order
  std::unique_ptr<esfleet::dds::TruthWriter> truth;
  std::vector<std::uint32_t> seq;  ///< next scan seq per robot

  Publisher(const SimOptions& o, const esfleet::sim::Fleet& fleet) {
    node = std::make_unique<esfleet::dds::Node>(
        esfleet::dds::NodeOptions{o.domain, o.profile, "esfleet-sim", o.secure});
    for (const auto& r : fleet.robots()) {
      scans.push_back(std::make_unique<esfleet::dds::ScanWriter>(*node, r.id()));
    }
    truth = std::make_unique<esfleet::dds::TruthWriter>(*node, esfleet::dds::kSimPartition);
    seq.assign(scans.size(), 0);
  }
  ~Publisher() {
    // Writers before the node (node.hpp).
    truth.reset();
    scans.clear();
    node.reset();
  }
  /// Scan readers matched, summed over the robots' writers (a reader of every robot counts once
  /// per robot).
  int scan_readers() const {
    int n = 0;
    for (const auto& w : scans) n += w->matched_readers();
    return n;
  }
  std::uint64_t scans_written() const {
    std::uint64_t n = 0;
    for (const auto& w : scans) n += w->samples_written();
    return n;
  }
  std::uint64_t scan_bytes() const {
    std::uint64_t n = 0;
    for (const auto& w : scans) n += w->bytes_written();
    return n;
  }
  /// Waits (up to `timeout` per writer) for every matched reader to acknowledge every scan.
  bool wait_for_scan_acks(std::chrono::milliseconds timeout) const {
    bool ok = true;
    for (const auto& w : scans) {
      if (w->matched_readers() > 0) ok = w->wait_for_acknowledgments(timeout) && ok;
    }
    return ok;
  }
  void publish(std::size_t index, const esfleet::sim::RobotSample& s) {
    const std::string& id = s.robot->id();
    if (!scans[index]->write(esfleet::dds::scan_to_msg(id, seq[index]++, s.scan))) {
      spdlog::warn("DDS refused a scan of {}", id);
    }
    if (!truth->write(esfleet::dds::truth_to_msg(id, s.truth))) {
      spdlog::warn("DDS refused a truth sample of {}", id);
    }
  }
  void wait_for_readers(int count, double timeout_s) {
    if (count <= 0) return;
    spdlog::info("waiting up to {} s for {} scan reader(s)", timeout_s, count);
    const auto deadline = Clock::now() + std::chrono::duration<double>(timeout_s);
    while (!g_stop.load() && Clock::now() < deadline && scan_readers() < count) {
      std::this_thread::sleep_for(kPoll);
    }
    if (scan_readers() < count && !g_stop.load()) {
      spdlog::warn("only {} of {} scan reader(s) matched: starting anyway", scan_readers(), count);
    }
  }
};

/// Parses the command line into `o`; returns an exit code if the program should stop.
std::optional<int> parse(int argc, char** argv, SimOptions& o) {
  CLI::App cli{
      "esfleet-sim: simulates a fleet of robots driving through a world map (ROS map_server "
      "YAML + image) and publishes each robot's laser scans, with noisy odometry, on "
      "esfleet/robots/scan (robot ids <prefix>1..N) and its true pose on esfleet/sim/truth, in "
      "real time at --rate. --out-log also writes <dir>/<id>.log (CARMEN) and <dir>/<id>.truth; "
      "with --offline it only writes them, as fast as possible. Robots do not see or avoid each "
      "other. The model: docs/sim.md.\n"
      "Exit codes: 0 done, 2 usage error or bad world file, 130 stopped by a signal.",
      "esfleet-sim"};
  auto& f = o.fleet;
  double start_stamp = -1.0;
  cli.add_option("--world", o.world, "world map: ROS map_server YAML (PGM or PNG image)")
      ->required();
  cli.add_option("--robots", f.robots, "number of robots")->capture_default_str();
  cli.add_option("--id-prefix", f.id_prefix, "robot k (1..N) is <prefix><k>")
      ->capture_default_str();
  cli.add_option("--seed", f.seed, "seed of everything random (starts, goals, noise)")
      ->capture_default_str();
  cli.add_option("--speed", f.motion.speed, "maximum forward speed, m/s")->capture_default_str();
  cli.add_option("--turn-rate", f.motion.turn_rate_deg, "maximum turn rate, deg/s")
      ->capture_default_str();
  cli.add_option("--clearance", f.motion.clearance,
                 "least distance (m) of a robot's centre to occupied or unknown space")
      ->capture_default_str();
  cli.add_option("--plan-cell", f.motion.plan_cell, "A* grid cell, m (whole world cells)")
      ->capture_default_str();
  cli.add_option("--rate", f.rate, "scans per second per robot (Hz)")->capture_default_str();
  cli.add_option("--beams", f.laser.beams, "beams per scan")->capture_default_str();
  cli.add_option("--fov", f.laser.fov_deg, "field of view, deg, centred forward")
      ->capture_default_str();
  cli.add_option("--max-range", f.laser.max_range,
                 "m; a beam that hits nothing closer reports this (a no-return)")
      ->capture_default_str();
  cli.add_option("--range-noise", f.laser.range_noise, "sigma of the range noise, m")
      ->capture_default_str();
  cli.add_option("--dropout", f.laser.dropout, "probability per beam of a no-return")
      ->capture_default_str();
  cli.add_option("--odom-noise-xy", f.odometry.noise_xy, "odometry x/y sigma per metre, m/m")
      ->capture_default_str();
  cli.add_option("--odom-noise-theta", f.odometry.noise_theta,
                 "odometry heading sigma per radian turned, rad/rad")
      ->capture_default_str();
  cli.add_option("--odom-noise-theta-per-m", f.odometry.noise_theta_per_m,
                 "odometry heading sigma per metre driven, rad/m")
      ->capture_default_str();
  cli.add_option("--start-stamp", start_stamp,
                 "stamp (s) of sim time 0; default: the wall clock at start, whole seconds");
  cli.add_option("--duration", o.duration, "seconds of sim time; 0 = until SIGINT/SIGTERM")
      ->capture_default_str();
  esfleet::app::add_dds_flags(cli, o.domain, o.profile, o.secure);
  cli.add_option("--wait-subscribers", o.wait_subscribers,
                 "before the first tick, wait until N scan readers are matched (summed over "
                 "the robots: a reader of every robot counts once per robot)")
      ->capture_default_str();
  cli.add_option("--wait-timeout", o.wait_timeout, "wait at most S seconds, then start anyway")
      ->capture_default_str();
  cli.add_option("--out-log", o.out_log,
                 "also write DIR/<id>.log (CARMEN ODOM + FLASER) and DIR/<id>.truth");
  cli.add_flag("--offline", o.offline,
               "no DDS: write --out-log as fast as possible for --duration s of sim time");
  try {
    cli.parse(argc, argv);
    f.start_stamp = start_stamp >= 0.0
                        ? start_stamp
                        : std::floor(std::chrono::duration<double>(
                                         std::chrono::system_clock::now().time_since_epoch())
                                         .count());
    if (cli.count("--start-stamp") > 0 && !(start_stamp >= 0.0)) {
      throw std::invalid_argument("--start-stamp must be >= 0");
    }
    o.validate();
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return cli.exit(e);  // --help
    spdlog::error("{} (run with --help for usage)", e.what());
    return kExitError;
  } catch (const std::exception& e) {
    spdlog::error("{} (run with --help for usage)", e.what());
    return kExitError;
  }
  return std::nullopt;
}

void log_config(const SimOptions& o, const esfleet::sim::Fleet& fleet) {
  const auto& f = o.fleet;
  spdlog::info("seed {}; {} robot(s) '{}1'..; rate {} Hz; start stamp {:.0f}", f.seed, f.robots,
               f.id_prefix, f.rate, f.start_stamp);
  spdlog::info(
      "motion: speed {} m/s, turn rate {} deg/s, clearance {} m, plan cell {} m "
      "({} open cells, largest component {:.1f} m^2 of {})",
      f.motion.speed, f.motion.turn_rate_deg, f.motion.clearance, fleet.plan_grid().cell_size(),
      fleet.plan_grid().open_count(),
      static_cast<double>(fleet.plan_grid().component_cells(0).size()) *
          fleet.plan_grid().cell_size() * fleet.plan_grid().cell_size(),
      fleet.plan_grid().component_count());
  spdlog::info("laser: {} beams over {} deg, max range {} m, range noise {} m, dropout {}",
               f.laser.beams, f.laser.fov_deg, f.laser.max_range, f.laser.range_noise,
               f.laser.dropout);
  spdlog::info("odometry noise: {} m/m, {} rad/rad, {} rad/m; {}{}", f.odometry.noise_xy,
               f.odometry.noise_theta, f.odometry.noise_theta_per_m,
               o.offline ? "offline" : fmt::format("DDS domain {}", o.domain),
               o.out_log.empty() ? "" : ", logs in " + o.out_log);
  for (const auto& r : fleet.robots()) {
    spdlog::info("{} starts at ({:.2f}, {:.2f}, {:.1f} deg)", r.id(), r.truth().x, r.truth().y,
                 esfleet::rad_to_deg(r.truth().theta));
  }
}

}  // namespace

int main(int argc, char** argv) {
  using namespace esfleet;
  spdlog::set_default_logger(spdlog::stderr_color_st("sim"));
  spdlog::set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");

  SimOptions o;
  if (const auto rc = parse(argc, argv, o)) return *rc;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);

  std::unique_ptr<sim::World> world;
  std::unique_ptr<sim::Fleet> fleet;
  try {
    world = std::make_unique<sim::World>(sim::load_world(o.world));
    fleet = std::make_unique<sim::Fleet>(*world, o.fleet);
  } catch (const std::invalid_argument& e) {
    spdlog::error("{}", e.what());
    return kExitError;
  } catch (const std::exception& e) {
    const std::string what = e.what();
    // load_world's messages name the file already; the others get it here.
    spdlog::error("{}", what.rfind(o.world, 0) == 0 ? what : o.world + ": " + what);
    return kExitError;
  }
  log_config(o, *fleet);

  std::vector<sim::RobotLogWriter> logs;
  std::unique_ptr<Publisher> publisher;
  try {
    if (!o.out_log.empty()) {
      std::filesystem::create_directories(o.out_log);
      for (const auto& r : fleet->robots()) logs.emplace_back(o.out_log, r.id());
    }
    if (!o.offline) {
      publisher = std::make_unique<Publisher>(o, *fleet);
      publisher->wait_for_readers(o.wait_subscribers, o.wait_timeout);
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return kExitError;
  }

  const double dt = 1.0 / o.fleet.rate;
  const auto max_ticks =
      o.duration > 0.0 ? static_cast<std::uint64_t>(std::llround(o.duration * o.fleet.rate)) : 0;
  const auto flush_every = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(o.fleet.rate));
  const auto start = Clock::now();
  auto next_progress = start + kProgressPeriod;
  const double cpu_start = process_cpu_seconds();
  double tick_cpu = 0.0, tick_cpu_max = 0.0;
  bool ok = true;
  while (!g_stop.load() && (max_ticks == 0 || fleet->ticks() < max_ticks)) {
    if (publisher) {  // real time: tick k at k * dt after the start
      const auto due =
          start + std::chrono::duration_cast<Clock::duration>(
                      std::chrono::duration<double>(static_cast<double>(fleet->ticks() + 1) * dt));
      while (Clock::now() < due && !g_stop.load()) {
        std::this_thread::sleep_until(std::min(due, Clock::now() + kPoll));
      }
      if (g_stop.load()) break;
    }
    const double c0 = thread_cpu_seconds();
    const auto& samples = fleet->tick();
    const double c = thread_cpu_seconds() - c0;
    tick_cpu += c;
    tick_cpu_max = std::max(tick_cpu_max, c);
    try {
      for (std::size_t i = 0; i < samples.size(); ++i) {
        if (publisher) publisher->publish(i, samples[i]);
        if (!logs.empty()) {
          const auto& s = samples[i];
          logs[i].write(s.scan, s.truth.pose, s.robot->speed(), s.robot->turn_rate());
        }
      }
      if (fleet->ticks() % flush_every == 0) {
        for (auto& l : logs) l.flush();
      }
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
      ok = false;
      break;
    }
    if (Clock::now() >= next_progress) {
      next_progress += kProgressPeriod;
      const double wall = std::chrono::duration<double>(Clock::now() - start).count();
      spdlog::info(
          "sim time {:.1f} s: {} ticks, {} robots, CPU {:.0f}% of a core, {:.2f} ms per "
          "tick (motion + scans){}",
          fleet->sim_time(), fleet->ticks(), fleet->robots().size(),
          100.0 * (process_cpu_seconds() - cpu_start) / wall,
          1e3 * tick_cpu / static_cast<double>(fleet->ticks()),
          publisher ? fmt::format(", {} scan reader(s)", publisher->scan_readers())
                    : std::string());
    }
  }
  const bool interrupted = g_stop.load();
  try {
    for (auto& l : logs) l.flush();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    ok = false;
  }
  if (publisher && !publisher->wait_for_scan_acks(kFinalAckTimeout)) {
    spdlog::warn("scan readers did not acknowledge the last scans within {} s",
                 kFinalAckTimeout.count());
  }

  const double wall = std::chrono::duration<double>(Clock::now() - start).count();
  const double ticks = static_cast<double>(std::max<std::uint64_t>(1, fleet->ticks()));
  spdlog::info(
      "{}{} ticks ({:.1f} s of sim time) in {:.1f} s, {} robots; CPU per tick: {:.3f} ms "
      "mean, {:.3f} ms max (motion + scans), {:.3f} ms all included",
      interrupted ? "interrupted: " : "", fleet->ticks(), fleet->sim_time(), wall,
      fleet->robots().size(), 1e3 * tick_cpu / ticks, 1e3 * tick_cpu_max,
      1e3 * (process_cpu_seconds() - cpu_start) / ticks);
  for (const auto& r : fleet->robots()) {
    spdlog::info(
        "{}: {:.1f} m driven, {} goals reached, {} blocked sub-steps, {} planning "
        "failures; truth ({:.2f}, {:.2f}), odometry ({:.2f}, {:.2f})",
        r.id(), r.distance(), r.goals_reached(), r.blocked_steps(), r.planning_failures(),
        r.truth().x, r.truth().y, r.odometry().x, r.odometry().y);
  }
  if (publisher) {
    spdlog::info(
        "published {} scans and {} truth samples ({:.1f} kB)", publisher->scans_written(),
        publisher->truth->samples_written(),
        static_cast<double>(publisher->scan_bytes() + publisher->truth->bytes_written()) / 1e3);
  }
  publisher.reset();  // deletes the DDS participant
  if (!ok) return kExitError;
  return interrupted ? kExitInterrupted : 0;
}
