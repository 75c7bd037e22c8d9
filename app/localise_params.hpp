#pragma once
// The follower's localisation parameters (LocaliserConfig, minus the SLAM tracking ones which
// add_slam_params registers) as a ParamTable section, shared by esfleet-follower and
// esfleet-bench localise.

#include "app/param_table.hpp"
#include "esfleet/core/localiser.hpp"

namespace esfleet::app {

/// Registers the localise_* parameters. The pointer must outlive the table.
void add_localise_params(ParamTable& table, LocaliserConfig* config);

/// Parses a hint "x,y,theta_deg[,radius_m[,angle_deg]]"; throws std::invalid_argument naming
/// what is wrong.
PoseHint parse_hint(const std::string& text);

}  // namespace esfleet::app
