#include "sim_app.hpp"

#include <spdlog/spdlog.h>
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <thread>

#include "app/program.hpp"
#include "esfleet/core/clock.hpp"
#include "esfleet/dds/node.hpp"
#include "esfleet/dds/to_msg.hpp"
#include "esfleet/dds/writer.hpp"

namespace esfleet::sim {

using app::UsageError;

namespace {

constexpr std::chrono::milliseconds kPoll{100};
constexpr std::chrono::seconds kProgressPeriod{5};
constexpr std::chrono::seconds kFinalAckTimeout{3};

/// User + system CPU of the whole process (DDS threads included), seconds.
double process_cpu_seconds() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  auto secs = [](const timeval& tv) {
    return static_cast<double>(tv.tv_sec) + static_cast<double>(tv.tv_usec) * 1e-6;
  };
  return secs(ru.ru_utime) + secs(ru.ru_stime);
}

}  // namespace

/// The DDS side: one participant, one scan writer per robot (in the robot's partition, so a
/// reader of one robot gets only its scans; docs/security.md) and the truth writer (partition
/// "sim").
class ScanPublisher {
 public:
  /// Throws app::UsageError naming the entity that could not be created.
  ScanPublisher(const SimOptions& o, const Fleet& fleet) {
    try {
      node_ = std::make_unique<dds::Node>(
          dds::NodeOptions{o.domain, o.profile, "esfleet-sim", o.secure});
    } catch (const std::exception& e) {
      throw UsageError(fmt::format("DDS participant on domain {}: {}", o.domain, e.what()));
    }
    try {
      for (const auto& r : fleet.robots()) {
        scans_.push_back(std::make_unique<dds::ScanWriter>(*node_, r.id()));
      }
      truth_ = std::make_unique<dds::TruthWriter>(*node_, dds::kSimPartition);
    } catch (const std::exception& e) {
      throw UsageError(fmt::format("DDS writers on domain {}: {}", o.domain, e.what()));
    }
    seq_.assign(scans_.size(), 0);
  }
  ~ScanPublisher() {
    // Writers before the node (node.hpp).
    truth_.reset();
    scans_.clear();
    node_.reset();
  }
  ScanPublisher(const ScanPublisher&) = delete;
  ScanPublisher& operator=(const ScanPublisher&) = delete;

  /// Scan readers matched, summed over the robots' writers (a reader of every robot counts once
  /// per robot).
  int scan_readers() const {
    int n = 0;
    for (const auto& w : scans_) n += w->matched_readers();
    return n;
  }
  std::uint64_t scans_written() const {
    std::uint64_t n = 0;
    for (const auto& w : scans_) n += w->samples_written();
    return n;
  }
  std::uint64_t scan_bytes() const {
    std::uint64_t n = 0;
    for (const auto& w : scans_) n += w->bytes_written();
    return n;
  }
  const dds::TruthWriter& truth() const { return *truth_; }
  /// Waits (up to `timeout` per writer) for every matched reader to acknowledge every scan.
  bool wait_for_scan_acks(std::chrono::milliseconds timeout) const {
    bool ok = true;
    for (const auto& w : scans_) {
      if (w->matched_readers() > 0) ok = w->wait_for_acknowledgments(timeout) && ok;
    }
    return ok;
  }
  void publish(std::size_t index, const RobotSample& s) {
    const std::string& id = s.robot->id();
    if (!scans_[index]->write(dds::scan_to_msg(id, seq_[index]++, s.scan))) {
      spdlog::warn("DDS refused a scan of {}", id);
    }
    if (!truth_->write(dds::truth_to_msg(id, s.truth))) {
      spdlog::warn("DDS refused a truth sample of {}", id);
    }
  }
  void wait_for_readers(int count, double timeout_s, const std::atomic<bool>& stop) const {
    if (count <= 0) return;
    spdlog::info("waiting up to {} s for {} scan reader(s)", timeout_s, count);
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (!stop.load() && std::chrono::steady_clock::now() < deadline && scan_readers() < count) {
      std::this_thread::sleep_for(kPoll);
    }
    if (scan_readers() < count && !stop.load()) {
      spdlog::warn("only {} of {} scan reader(s) matched: starting anyway", scan_readers(), count);
    }
  }

 private:
  std::unique_ptr<dds::Node> node_;
  std::vector<std::unique_ptr<dds::ScanWriter>> scans_;  ///< per robot, fleet order
  std::unique_ptr<dds::TruthWriter> truth_;
  std::vector<std::uint32_t> seq_;  ///< next scan seq per robot
};

SimApp::SimApp(SimOptions options, const std::atomic<bool>& stop)
    : o_(std::move(options)), stop_(stop) {
  try {
    world_ = std::make_unique<World>(load_world(o_.world));
  } catch (const std::exception& e) {
    throw UsageError(app::name_flag("--world", o_.world, e.what()));
  }
  try {
    fleet_ = std::make_unique<Fleet>(*world_, o_.fleet_config());
  } catch (const std::invalid_argument&) {
    throw;  // a bad config: the message names the flag
  } catch (const std::exception& e) {
    throw UsageError(app::name_flag("--world", o_.world, e.what()));  // e.g. no drivable space
  }
  log_config();
  if (!o_.out_log.empty()) {
    try {
      std::filesystem::create_directories(o_.out_log);
      for (const auto& r : fleet_->robots()) logs_.emplace_back(o_.out_log, r.id());
    } catch (const std::exception& e) {
      throw UsageError(app::name_flag("--out-log", o_.out_log, e.what()));
    }
  }
  if (!o_.offline) publisher_ = std::make_unique<ScanPublisher>(o_, *fleet_);
}

SimApp::~SimApp() {
  publisher_.reset();  // deletes the DDS participant (its writers first)
}

int SimApp::run() {
  if (publisher_) publisher_->wait_for_readers(o_.wait_subscribers, o_.wait_timeout, stop_);
  const auto max_ticks =
      o_.duration > 0.0 ? static_cast<std::uint64_t>(std::llround(o_.duration * o_.fleet.rate)) : 0;
  start_ = Clock::now();
  cpu_start_ = process_cpu_seconds();
  auto next_progress = start_ + kProgressPeriod;
  bool ok = true;
  while (!stop_.load() && (max_ticks == 0 || fleet_->ticks() < max_ticks)) {
    if (!wait_for_tick()) break;
    try {
      tick();
    } catch (const std::exception& e) {
      spdlog::error("{}", e.what());
      ok = false;
      break;
    }
    if (Clock::now() >= next_progress) {
      next_progress += kProgressPeriod;
      log_progress();
    }
  }
  const bool interrupted = stop_.load();
  try {
    for (auto& l : logs_) l.flush();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    ok = false;
  }
  if (publisher_ && !publisher_->wait_for_scan_acks(kFinalAckTimeout)) {
    spdlog::warn("scan readers did not acknowledge the last scans within {} s",
                 kFinalAckTimeout.count());
  }
  log_report(interrupted);
  publisher_.reset();  // deletes the DDS participant
  // A log that could not be written exits 2, as esfleet-sim always has (callers may test it).
  if (!ok) return app::kExitUsage;
  return interrupted ? app::kExitInterrupted : app::kExitOk;
}

bool SimApp::wait_for_tick() const {
  if (!publisher_) return true;  // offline: as fast as possible
  const double dt = 1.0 / o_.fleet.rate;
  const auto due =
      start_ + std::chrono::duration_cast<Clock::duration>(
                   std::chrono::duration<double>(static_cast<double>(fleet_->ticks() + 1) * dt));
  while (Clock::now() < due && !stop_.load()) {
    std::this_thread::sleep_until(std::min(due, Clock::now() + kPoll));
  }
  return !stop_.load();
}

void SimApp::tick() {
  const double c0 = thread_cpu_seconds();
  const auto& samples = fleet_->tick();
  const double c = thread_cpu_seconds() - c0;
  tick_cpu_ += c;
  tick_cpu_max_ = std::max(tick_cpu_max_, c);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (publisher_) publisher_->publish(i, samples[i]);
    if (!logs_.empty()) {
      const auto& s = samples[i];
      logs_[i].write(s.scan, s.truth.pose, s.robot->speed(), s.robot->turn_rate());
    }
  }
  // Flushed once per second of sim time.
  const auto flush_every = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(o_.fleet.rate));
  if (fleet_->ticks() % flush_every == 0) {
    for (auto& l : logs_) l.flush();
  }
}

void SimApp::log_config() const {
  const FleetConfig& f = fleet_->config();
  spdlog::info("seed {}; {} robot(s) '{}1'..; rate {} Hz; start stamp {:.0f}", f.seed, f.robots,
               f.id_prefix, f.rate, f.start_stamp);
  const PlanGrid& grid = fleet_->plan_grid();
  spdlog::info(
      "motion: speed {} m/s, turn rate {} deg/s, clearance {} m, plan cell {} m "
      "({} open cells, largest component {:.1f} m^2 of {})",
      f.motion.speed, f.motion.turn_rate_deg, f.motion.clearance, grid.cell_size(),
      grid.open_count(),
      static_cast<double>(grid.component_cells(0).size()) * grid.cell_size() * grid.cell_size(),
      grid.component_count());
  spdlog::info("laser: {} beams over {} deg, max range {} m, range noise {} m, dropout {}",
               f.laser.beams, f.laser.fov_deg, f.laser.max_range, f.laser.range_noise,
               f.laser.dropout);
  spdlog::info("odometry noise: {} m/m, {} rad/rad, {} rad/m; {}{}", f.odometry.noise_xy,
               f.odometry.noise_theta, f.odometry.noise_theta_per_m,
               o_.offline ? "offline" : fmt::format("DDS domain {}", o_.domain),
               o_.out_log.empty() ? "" : ", logs in " + o_.out_log);
  for (const auto& r : fleet_->robots()) {
    spdlog::info("{} starts at ({:.2f}, {:.2f}, {:.1f} deg)", r.id(), r.truth().x, r.truth().y,
                 rad_to_deg(r.truth().theta));
  }
}

void SimApp::log_progress() const {
  const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
  spdlog::info(
      "sim time {:.1f} s: {} ticks, {} robots, CPU {:.0f}% of a core, {:.2f} ms per "
      "tick (motion + scans){}",
      fleet_->sim_time(), fleet_->ticks(), fleet_->robots().size(),
      100.0 * (process_cpu_seconds() - cpu_start_) / wall,
      1e3 * tick_cpu_ / static_cast<double>(fleet_->ticks()),
      publisher_ ? fmt::format(", {} scan reader(s)", publisher_->scan_readers()) : std::string());
}

void SimApp::log_report(bool interrupted) const {
  const double wall = std::chrono::duration<double>(Clock::now() - start_).count();
  const double ticks = static_cast<double>(std::max<std::uint64_t>(1, fleet_->ticks()));
  spdlog::info(
      "{}{} ticks ({:.1f} s of sim time) in {:.1f} s, {} robots; CPU per tick: {:.3f} ms "
      "mean, {:.3f} ms max (motion + scans), {:.3f} ms all included",
      interrupted ? "interrupted: " : "", fleet_->ticks(), fleet_->sim_time(), wall,
      fleet_->robots().size(), 1e3 * tick_cpu_ / ticks, 1e3 * tick_cpu_max_,
      1e3 * (process_cpu_seconds() - cpu_start_) / ticks);
  for (const auto& r : fleet_->robots()) {
    spdlog::info(
        "{}: {:.1f} m driven, {} goals reached, {} blocked sub-steps, {} planning "
        "failures; truth ({:.2f}, {:.2f}), odometry ({:.2f}, {:.2f})",
        r.id(), r.distance(), r.goals_reached(), r.blocked_steps(), r.planning_failures(),
        r.truth().x, r.truth().y, r.odometry().x, r.odometry().y);
  }
  if (publisher_) {
    spdlog::info(
        "published {} scans and {} truth samples ({:.1f} kB)", publisher_->scans_written(),
        publisher_->truth().samples_written(),
        static_cast<double>(publisher_->scan_bytes() + publisher_->truth().bytes_written()) / 1e3);
  }
}

}  // namespace esfleet::sim
