#pragma once
// The SLAM and log-reader parameters as one ParamTable section, shared by esfleet-leader,
// esfleet-follower and esfleet-bench so a flag means the same thing everywhere.

#include "app/param_table.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet::app {

/// Registers every SlamConfig field (the names under "SLAM parameters" in docs/programs.md) and
/// the reader's beam convention. The pointers must outlive the table.
void add_slam_params(ParamTable& table, SlamConfig* slam, CarmenReaderOptions* reader);

/// The names add_slam_params registers that a pose tracker uses (the ES, the prediction, the
/// motion prior, the reader's beams): the others build the map (its layout, the update, key
/// scans, loop closure, recovery), which a follower does not do.
bool is_tracking_param(const std::string& name);

}  // namespace esfleet::app
