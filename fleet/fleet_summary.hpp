#pragma once
// The launcher's summary of a run (--summary, summary.json): per robot what the launcher saw
// (localisation time, errors against the truth, CPU, memory, exit code) merged with what the
// follower wrote in its stats.json, and the fleet's totals. Pure: the caller reads the files.

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "fleet_monitor.hpp"
#include "fleet_options.hpp"

namespace esfleet::fleet {

/// The launcher's clock at the moments the summary refers to (seconds since it started).
struct FleetTimes {
  double end_s = 0.0;              ///< the run ended (before the programs were stopped)
  double followers_start_s = 0.0;  ///< the followers were started
  double window_start_s = -1.0;    ///< every follower tracked: window start; -1 = never
  /// Length of the real-time window (0 when it never started).
  double window_s() const { return window_start_s >= 0 ? end_s - window_start_s : 0.0; }
};

struct FleetSummary {
  nlohmann::json json;  ///< what summary.json holds
  int localised = 0;    ///< followers that declared a pose
  int realtime = 0;     ///< ... that kept up with the scans in the window
  int wrong = 0;        ///< ... that declared a wrong pose
};

/// One follower's entry. `stats`: its stats.json (an empty object when it wrote none). A robot
/// counts as real time when the window lasted >= 10 s, it published a tracking pose for
/// >= 98 % of the scans the simulator sent in it and its tracking lag p95 (from stats) stayed
/// below one scan period (1 / rate_hz).
nlohmann::json follower_summary(const ChildProcess& follower, const RobotReport& report,
                                const nlohmann::json& stats, const FleetTimes& times,
                                double rate_hz);

/// The whole summary. `follower_stats[i]` is followers[i]'s stats.json (or an empty object);
/// `failure` why the run ended early ("" = it ran as asked).
FleetSummary build_summary(const FleetOptions& o, const FleetTimes& times,
                           const std::string& failure, const ChildProcess& leader,
                           const ChildProcess& sim, const std::vector<ChildProcess>& followers,
                           const FleetMonitor& monitor,
                           const std::vector<nlohmann::json>& follower_stats);

/// The line printed at the end: "fleet of N: L localised, R in real time, W with a wrong pose;
/// summary PATH".
std::string summary_line(const FleetSummary& s, int robots, const std::string& path);

/// A follower's stats.json; an empty object if the file is missing or not JSON.
nlohmann::json read_stats_json(const std::string& path);

}  // namespace esfleet::fleet
