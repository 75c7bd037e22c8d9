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
std::vector<std::string> leader_argv(const FleetOptions& o, const std::string& bin_dir);

/// BIN/esfleet-follower for robot k (1..N): the scans of robot-k, robot id robot-k, seed
/// --seed + k, map and trajectory in OUT/robot-k; then the DDS flags and --follower-args.
std::vector<std::string> follower_argv(const FleetOptions& o, const std::string& bin_dir, int k);

/// BIN/esfleet-sim: --world with --robots at --rate, seed --seed; then the DDS flags and
/// --sim-args.
std::vector<std::string> sim_argv(const FleetOptions& o, const std::string& bin_dir);

/// BIN/esfleet-view on --view's port; then the DDS flags (identity "view") and --view-args.
std::vector<std::string> view_argv(const FleetOptions& o, const std::string& bin_dir);

}  // namespace esfleet::fleet
