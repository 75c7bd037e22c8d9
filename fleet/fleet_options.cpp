#include "fleet_options.hpp"

#include <cctype>
#include <filesystem>
#include <utility>

#include "app/program.hpp"

namespace esfleet::fleet {

namespace fs = std::filesystem;
using app::UsageError;

std::string robot_name(int k) { return "robot-" + std::to_string(k); }

std::string FleetOptions::summary_path() const {
  return summary.empty() ? out + "/summary.json" : summary;
}

std::string FleetOptions::bin_directory() const {
  return bin_dir.empty() ? fs::canonical("/proc/self/exe").parent_path().string() : bin_dir;
}

std::string FleetOptions::secure_dir_for(const std::string& id) const {
  return secure.empty() ? std::string() : (fs::path(secure) / id).string();
}

std::vector<std::string> FleetOptions::identities() const {
  std::vector<std::string> ids = {"leader", "sim", "monitor"};
  if (view_port >= 0) ids.push_back("view");
  for (int k = 1; k <= robots; ++k) ids.push_back(robot_name(k));
  return ids;
}

void FleetOptions::validate() const {
  // The ranges the flags check already; here too for options built in code.
  if (robots < 1 || robots > 64) throw UsageError("--robots must be in [1, 64]");
  if (!(duration >= 0.0)) throw UsageError("--duration must be >= 0");
  if (!(window >= 0.0)) throw UsageError("--window must be >= 0");
  if (domain < 0 || domain > 232) throw UsageError("--domain must be in [0, 232]");
  if (!(rate > 0.0)) throw UsageError("--rate must be > 0");
  if (!(leader_rate >= 0.0)) throw UsageError("--leader-rate must be >= 0");
  if (max_restarts < 0) throw UsageError("--max-restarts must be >= 0");
  if (max_leader_restarts < 0) throw UsageError("--max-leader-restarts must be >= 0");
  if (!netns.empty()) {
    // The testbed's names: esf-RUN-1 .. esf-RUN-K (deploy/netns/testbed.sh).
    for (const char ch : netns) {
      if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_') {
        throw UsageError("--netns " + netns + ": a testbed RUN name is letters, digits and _");
      }
    }
    const std::string last = "esf-" + netns + "-" + std::to_string(netns_hosts());
    if (!fs::exists("/var/run/netns/" + last)) {
      throw UsageError("--netns " + netns + ": no network namespace " + last + " (" +
                       std::to_string(netns_hosts()) +
                       " hosts needed: deploy/netns/testbed.sh up " + netns + " " +
                       std::to_string(netns_hosts()) + ")");
    }
  }
  if (view_port < -1 || view_port > 65535) throw UsageError("--view must be in [0, 65535]");
  for (const auto& [flag, path] :
       {std::pair{"--world", world}, std::pair{"--log", log}, std::pair{"--profile", profile}}) {
    if (!fs::is_regular_file(path))
      throw UsageError(std::string(flag) + " " + path + ": no such file");
  }
  // --secure: DIR/<id> for every identity the fleet uses (the Node checks the files in each).
  if (!secure.empty()) {
    for (const auto& id : identities()) {
      if (!fs::is_directory(secure_dir_for(id))) {
        throw UsageError("--secure " + secure + ": no directory " + secure_dir_for(id) +
                         " (make-fleet-certs.sh " + secure + " ... " + id + ")");
      }
    }
  }
  const std::string bin = bin_directory();
  for (const char* prog : {"esfleet-leader", "esfleet-follower", "esfleet-sim", "esfleet-view"}) {
    if (std::string(prog) == "esfleet-view" && view_port < 0) continue;
    if (access((bin + "/" + prog).c_str(), X_OK) != 0) {
      throw UsageError("--bin-dir " + bin + ": no executable " + prog);
    }
  }
}

void add_fleet_flags(CLI::App& cli, FleetOptions& o) {
  cli.add_option("--robots", o.robots, "simulated robots, one follower each")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cli.add_option("--duration", o.duration, "stop after S seconds (0 = on Ctrl-C only)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli.add_option("--window", o.window,
                 "stop once every follower has tracked for S seconds (the real-time window; 0 = "
                 "no such stop)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli.add_option("--summary", o.summary, "write the summary JSON here (default OUT/summary.json)");
  cli.add_option("--out", o.out, "directory for the programs' logs, maps and stats")
      ->capture_default_str();
  cli.add_option("--domain", o.domain, "DDS domain id of the fleet (0-232)")
      ->check(CLI::Range(0, 232))
      ->capture_default_str();
  cli.add_option("--profile", o.profile, "Fast DDS XML profile for every program")
      ->capture_default_str();
  cli.add_option("--secure", o.secure,
                 "DDS Security for every program: DIR/<id> per identity (leader, robot-1..N, "
                 "sim, monitor for this launcher, view with --view), as "
                 "deploy/security/make-fleet-certs.sh "
                 "makes them (docs/security.md)");
  cli.add_option("--world", o.world, "world map for the simulator (ROS map YAML)")
      ->capture_default_str();
  cli.add_option("--log", o.log, "CARMEN log the leader maps (its map's frame is the world's)")
      ->capture_default_str();
  cli.add_option("--rate", o.rate, "laser scans per second per robot")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cli.add_option("--leader-rate", o.leader_rate,
                 "leader's replay speed of --log (0 = as fast as it maps, 1 = recorded speed)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli.add_option("--seed", o.seed, "seed of the simulator (robot k's follower gets seed + k)")
      ->capture_default_str();
  cli.add_option("--leader-args", o.leader_args, "extra esfleet-leader flags (one string)")
      ->capture_default_str();
  cli.add_option("--follower-args", o.follower_args, "extra esfleet-follower flags (one string)")
      ->capture_default_str();
  cli.add_option("--sim-args", o.sim_args, "extra esfleet-sim flags (one string)");
  cli.add_option("--max-restarts", o.max_restarts,
                 "restart a follower that dies (crash, kill) up to N times, counted in the "
                 "summary; its old log is kept as robot-K.log.1, .2, ... (0 = a dead follower "
                 "ends the run)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli.add_option("--max-leader-restarts", o.max_leader_restarts,
                 "restart the leader when it dies up to N times, with --resume from its "
                 "checkpoint in OUT/leader when there is one; counted in the summary (0 = a dead "
                 "leader ends the run)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cli.add_option("--netns", o.netns,
                 "run each program in its own host of deploy/netns/testbed.sh RUN (needs "
                 "robots + 2 hosts): leader on host 1, simulator on 2, robot k's follower on "
                 "k + 2; use a --profile that reaches the other hosts (lan-udp.xml)");
  cli.add_flag("--wait-map", o.wait_map,
               "start the simulator and followers only once the leader's map is complete (the "
               "fleet joins a mapped building; scale measurements). Default: all at once, the "
               "followers localise while the map grows");
  cli.add_flag("--contribute", o.contribute,
               "map together: the followers contribute their scans once tracking and the leader "
               "checks and inserts them, so the shared map grows where the leader never was "
               "(docs/contribute.md); see --leader-scans");
  cli.add_option("--leader-scans", o.leader_scans,
                 "the leader maps only the first N scans of --log, then serves its map (and "
                 "with --contribute grows it with the followers' scans); 0 = the whole log")
      ->capture_default_str();
  cli.add_option("--view", o.view_port,
                 "also start esfleet-view on this port: the fleet in a browser at "
                 "http://HOST:PORT/ (docs/view.md; 0 = any free port, see OUT/view.log)")
      ->check(CLI::Range(0, 65535));
  cli.add_option("--view-args", o.view_args, "extra esfleet-view flags (one string)");
  cli.add_option("--bin-dir", o.bin_dir,
                 "where the esfleet programs are (default: next to this one)");
  cli.add_option("--live", o.live, "redraw a status table every second (default: on a terminal)");
}

}  // namespace esfleet::fleet
