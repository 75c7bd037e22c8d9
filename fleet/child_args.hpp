#pragma once
// The command lines the fleet launcher gives its programs: the leader maps --log and shares
// the map, robot k's follower localises from the scans of robot-k, the simulator drives the
// robots. Every one gets the fleet's DDS flags under its own identity. Pure: no processes.

#include <string>
#include <vector>

#include "fleet_options.hpp"

namespace esfleet::fleet {

/// Splits a flag string ("--odometry on --mu 50") at white space; no quoting.
std::vector<std::string> split_args(const std::string& s);

/// --domain and --profile of the fleet, plus --secure DIR/<id> when --secure is on.
std::vector<std::string> dds_args(const FleetOptions& o, const std::string& id);

/// BIN/esfleet-leader: maps --log at --leader-rate, lingers until stopped, writes OUT/leader;
/// then the DDS flags and --leader-args.
/// With `resume`: also --resume OUT/leader (the restart of a leader that died, from its
/// checkpoint).
std::vector<std::string> leader_argv(const FleetOptions& o, const std::string& bin_dir,
                                     bool resume = false);

/// BIN/esfleet-follower for robot k (1..N): the scans of robot-k, robot id robot-k, seed
/// --seed + k, map and trajectory in OUT/robot-k; then the DDS flags and --follower-args.
std::vector<std::string> follower_argv(const FleetOptions& o, const std::string& bin_dir, int k);

/// BIN/esfleet-sim: --world with --robots at --rate, seed --seed; then the DDS flags and
/// --sim-args.
std::vector<std::string> sim_argv(const FleetOptions& o, const std::string& bin_dir);

/// BIN/esfleet-view on --view's port; then the DDS flags (identity "view") and --view-args.
std::vector<std::string> view_argv(const FleetOptions& o, const std::string& bin_dir);

/// `argv` as run on testbed host `host` of --netns (ip netns exec esf-RUN-HOST ...); `argv`
/// itself when --netns is off. Throws std::runtime_error when no `ip` program is found.
std::vector<std::string> on_host(const FleetOptions& o, int host, std::vector<std::string> argv);

/// The testbed hosts of --netns: the leader's, the simulator's, robot k's follower's.
inline constexpr int kLeaderHost = 1;
inline constexpr int kSimHost = 2;
inline int follower_host(int k) { return k + 2; }

}  // namespace esfleet::fleet
