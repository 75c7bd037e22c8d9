#pragma once
// esfleet-sim's command line: what the simulator is asked to run (SimOptions), its checks
// (validate) and the flags that set it (add_sim_flags), apart from main() so that a test can
// parse an argv into it.

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "esfleet/sim/fleet.hpp"

namespace esfleet::sim {

struct SimOptions {
  std::string world;                  ///< ROS map_server YAML of the world (required)
  FleetConfig fleet;                  ///< robots, motion, sensor, odometry (start stamp below)
  std::optional<double> start_stamp;  ///< stamp of sim time 0; none = the wall clock at start
  double duration = 0.0;              ///< seconds of sim time; 0 = until SIGINT/SIGTERM
  int domain = 0;                     ///< DDS domain id
  std::string profile;                ///< Fast DDS XML profile; empty = Fast DDS defaults
  std::string secure;                 ///< DDS Security directory (docs/security.md); empty = off
  std::string out_log;                ///< directory for <id>.log and <id>.truth; empty = none
  bool offline = false;               ///< no DDS, as fast as possible (needs out_log, duration)
  int wait_subscribers = 0;           ///< before the first tick, wait for this many scan readers
                                      ///< (summed over the robots' writers)
  double wait_timeout = 30.0;         ///< ... at most this many seconds

  /// `fleet` with its start stamp: --start-stamp, or the wall clock now in whole seconds.
  FleetConfig fleet_config() const;
  /// Throws app::UsageError naming the flag (the fleet's fields included).
  void validate() const;
};

/// Registers esfleet-sim's flags on `cli`, bound to `o` (its values are the defaults shown).
void add_sim_flags(CLI::App& cli, SimOptions& o);

}  // namespace esfleet::sim
