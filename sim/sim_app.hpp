#pragma once
// esfleet-sim's application: drives the simulated fleet (esfleet/sim/fleet.hpp) tick by tick and
// publishes each robot's scans and true poses over DDS in real time, and/or writes them as
// CARMEN logs and true trajectories (--out-log), as fast as possible with --offline.
//
// Life cycle: the constructor loads the world, places the robots, opens the log files and
// creates the DDS participant and writers (not with --offline), in that order; run() waits for
// the scan readers (--wait-subscribers), ticks until --duration or the stop flag, flushes, waits
// a little for the readers' acknowledgments and reports; the destructor deletes the writers
// before the participant.

#include <atomic>
#include <chrono>
#include <memory>
#include <vector>

#include "esfleet/sim/fleet.hpp"
#include "esfleet/sim/log_writer.hpp"
#include "esfleet/sim/world.hpp"
#include "sim_options.hpp"

namespace esfleet::sim {

class ScanPublisher;

class SimApp {
 public:
  /// `options` must have passed validate(); `stop` is the SIGINT/SIGTERM flag. Throws
  /// app::UsageError naming the step that failed ("--world FILE: ...", "--out-log DIR: ...",
  /// "DDS participant on domain N: ...") and std::invalid_argument for a bad fleet config.
  SimApp(SimOptions options, const std::atomic<bool>& stop);
  ~SimApp();
  SimApp(const SimApp&) = delete;
  SimApp& operator=(const SimApp&) = delete;

  /// Runs the simulation. Returns 0 after --duration, 130 when stopped by the stop flag (the
  /// outputs are complete up to the last tick either way), 2 when writing a log failed.
  int run();

  const Fleet& fleet() const { return *fleet_; }

 private:
  using Clock = std::chrono::steady_clock;

  /// Logs the effective configuration and where each robot starts.
  void log_config() const;
  /// Real time: sleeps until tick k is due at k / rate after the start. False if stopped.
  bool wait_for_tick() const;
  /// One tick: moves the robots, publishes and writes their samples. Throws on a write error.
  void tick();
  void log_progress() const;
  void log_report(bool interrupted) const;

  SimOptions o_;
  const std::atomic<bool>& stop_;
  std::unique_ptr<World> world_;
  std::unique_ptr<Fleet> fleet_;
  std::vector<RobotLogWriter> logs_;            ///< per robot, fleet order; none without --out-log
  std::unique_ptr<ScanPublisher> publisher_;    ///< none with --offline
  Clock::time_point start_ = Clock::now();      ///< of the ticks
  double cpu_start_ = 0.0;                      ///< process CPU seconds at the start
  double tick_cpu_ = 0.0, tick_cpu_max_ = 0.0;  ///< thread CPU seconds in Fleet::tick
};

}  // namespace esfleet::sim
