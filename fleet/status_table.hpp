#pragma once
// The launcher's status table: the leader's and the simulator's CPU and memory and the map's
// progress, then one line per robot (state, time to localise, error against the truth, CPU,
// memory, poses per second). Text only; the launcher prints it (redrawn on a terminal).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "fleet_monitor.hpp"

namespace esfleet::fleet {

/// The leader's map summary as the table shows it (from msg::MapMeta).
struct MapProgress {
  std::uint32_t tiles = 0;  ///< tiles the map holds
  std::uint32_t scans = 0;  ///< scans inserted so far
  bool complete = false;    ///< the leader's log has ended
  /// Tiles when the leader's map was first seen complete (its own mapping done); 0 = not yet.
  std::uint32_t tiles_when_complete = 0;
};

/// The name of a msg::RobotPose status ("tracking", ...); "-" for kStatusNone and unknowns.
const char* status_name(std::uint8_t status);

/// What the table header says about the run.
struct StatusHeader {
  int robots = 0;                  ///< --robots
  int domain = 0;                  ///< --domain
  double now_s = 0.0;              ///< launcher time
  double duration_s = 0.0;         ///< --duration; 0 = none
  double followers_start_s = 0.0;  ///< launcher time the followers were started
  std::optional<MapProgress> map;  ///< the leader's last map summary; none yet
};

/// Renders the table. Keeps each robot's pose count of the previous render to show poses per
/// second since then.
class StatusTable {
 public:
  /// What the robot columns mean, printed once before the first table; `wrong` is the
  /// tolerance beyond which a declared pose counts as wrong.
  static std::string legend(const Tolerance& wrong);

  /// `followers[i]` is the robot monitor.robots().at(followers[i].name) (registered there);
  /// `dt_s` the seconds since the previous render (poses/s is 0 when dt_s <= 0).
  std::string render(const StatusHeader& header, const ChildProcess& leader,
                     const ChildProcess& sim, const std::vector<ChildProcess>& followers,
                     const FleetMonitor& monitor, double dt_s);

 private:
  std::map<std::string, std::size_t> poses_at_last_render_;
};

}  // namespace esfleet::fleet
