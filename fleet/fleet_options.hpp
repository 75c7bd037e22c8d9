#pragma once
// esfleet-fleet's command line: what the launcher is asked to run (FleetOptions), its checks
// (validate) and the flags that set it (add_fleet_flags), apart from main() so that a test can
// parse an argv into it.

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace esfleet::fleet {

struct FleetOptions {
  /// Simulated robots, one follower each, [1, 64].
  int robots = 4;
  /// Stop after this many seconds; 0 = on Ctrl-C only.
  double duration = 0.0;
  /// Stop once every follower has tracked this many seconds (the real-time window); 0 = never.
  double window = 0.0;
  /// Summary JSON file; empty = OUT/summary.json (summary_path()).
  std::string summary;
  /// Directory for the programs' logs, maps and stats.
  std::string out = "out/fleet";
  /// DDS domain id of the fleet, [0, 232].
  int domain = 78;
  /// Fast DDS XML profile for every program.
  /// UDP on 127.0.0.1: with shared memory a follower restarted after a SIGKILL can get nothing
  /// (docs/faults.md, "Shared memory and killed processes").
  std::string profile = "deploy/fastdds/localhost-udp.xml";
  /// DDS Security: DIR/<id> per identity (identities()); empty = off.
  std::string secure;
  /// The simulator's world (ROS map YAML): the leader's map of `log`, so both share one frame.
  std::string world = "data/worlds/mit-csail/map.yaml";
  /// CARMEN log the leader maps.
  std::string log = "data/mit-csail/mit-csail.clf.gz";
  /// Laser scans per second per robot, > 0.
  double rate = 5.0;
  /// The leader's replay speed of `log`: 0 = as fast as it maps, 1 = recorded speed.
  double leader_rate = 0.0;
  /// Seed of the simulator; robot k's follower gets seed + k.
  unsigned seed = 1;
  /// Extra esfleet-leader flags, one string split at white space.
  /// The flags data/worlds/mit-csail was mapped with: the leader's map frame is then the
  /// simulated world's, point for point (data/worlds/README.md).
  std::string leader_args =
      "--odometry on --loop-final off --loop-window-max-xy 0 --free-margin 0 "
      "--search-point-spacing 0";
  /// Extra esfleet-follower flags, one string split at white space.
  std::string follower_args = "--odometry on";
  /// Extra esfleet-sim flags, one string split at white space.
  std::string sim_args;
  /// Times each follower is restarted after it died (crash, SIGKILL) before its death ends the
  /// run as a failure; 0 = the first death of a follower ends the run. Restarts are counted in
  /// the summary.
  int max_restarts = 5;
  /// Times the leader is restarted after it died, as its systemd unit would (Restart=
  /// on-failure): with --resume OUT/leader when it left a checkpoint there, else anew. 0 = the
  /// leader's death ends the run. Counted in the summary.
  int max_leader_restarts = 5;
  /// Run every program in a host of its own of deploy/netns/testbed.sh RUN (network namespace
  /// esf-RUN-i): the leader on host 1, the simulator on 2, robot k's follower on k + 2. The
  /// launcher itself (and esfleet-view) stays where it is started, normally on host 1 (the
  /// soak, tools/soak.sh). Empty = all on this host.
  std::string netns;
  /// Start the simulator and the followers only once the leader's map is complete.
  bool wait_map = false;
  /// Map together (docs/contribute.md): the leader accepts contributed scans
  /// (--accept-contributions) and every follower contributes its own (--contribute).
  bool contribute = false;
  /// The leader maps only the first N scans of --log (--max-scans; 0 = all), then serves and,
  /// with `contribute`, grows the map with the followers' scans.
  unsigned long leader_scans = 0;
  /// esfleet-view's port: the fleet in a browser at http://HOST:PORT/ (docs/view.md); -1 = no
  /// view, 0 = any free port (in OUT/view.log).
  int view_port = -1;
  /// Extra esfleet-view flags, one string split at white space (e.g. "--bind 127.0.0.1").
  std::string view_args;
  /// Where the esfleet programs are; empty = next to this executable (bin_directory()).
  std::string bin_dir;
  /// Redraw the status table every second (else print it every 5 s); default: on a terminal.
  bool live = isatty(STDOUT_FILENO) != 0;

  /// Hosts --netns needs: robots + 2.
  int netns_hosts() const { return robots + 2; }
  /// --summary, or OUT/summary.json when it is empty.
  std::string summary_path() const;
  /// --bin-dir, or the directory of the running executable when it is empty.
  std::string bin_directory() const;
  /// The DDS Security directory of identity `id` (DIR/<id>); empty when --secure is off.
  std::string secure_dir_for(const std::string& id) const;
  /// Every DDS identity of the fleet: leader, sim, monitor (this launcher), view (with --view),
  /// robot-1..N.
  std::vector<std::string> identities() const;

  /// Throws app::UsageError naming the flag: a value out of range, a missing --world, --log or
  /// --profile file, a missing --secure identity directory, a --bin-dir without the programs.
  /// Looks at the file system; loads nothing (FleetApp loads the world).
  void validate() const;
};

/// Registers esfleet-fleet's flags on `cli`, bound to `o` (its values are the defaults shown).
void add_fleet_flags(CLI::App& cli, FleetOptions& o);

/// Robot k's name (k = 1..N): its follower's robot id, log and output directory name.
std::string robot_name(int k);

}  // namespace esfleet::fleet
