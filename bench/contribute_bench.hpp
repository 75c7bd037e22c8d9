#pragma once
// esfleet-bench contribute: mapping together, without a network (docs/contribute.md). The
// leader maps the first half of a log and stops; followers run the second half from case (b)
// starts (drawn where the half map covers them; the first starts --lead-in scans before the
// half, on the leader's path, since where the leader stops the log often enters new space at
// once and a follower cannot localise there), each on its
// own stretch of the log up to the next robot's start plus an overlap, all at once (their scans
// interleaved by time since their own start). Each localises with no hint in the leader's map
// as it stands and, once tracking, contributes its scans; the leader checks and inserts them
// (Slam::contribute) and the followers' maps follow the leader's changed tiles. Scored against
// the leader's map of the whole log (coverage) and the relations (the followers' tracked poses,
// and the combined trajectory: the leader's first half, then the followers'); evaluation only.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "app/param_table.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/contribution.hpp"
#include "esfleet/core/localiser.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet::bench {

struct ContributeBenchOptions {
  std::string log;
  std::string relations;  ///< ground truth for the trajectories (evaluation only)
  double time_offset = 0.0;
  int robots = 4;
  std::uint64_t seed = 1;  ///< the draw of the starts and the localisers' seeds
  int overlap = 300;       ///< scans a robot drives on past the next robot's start
  /// The first follower starts this many scans before the leader's last one (0: at the half).
  int lead_in = 200;
  double leader_share = 0.5;  ///< the part of the log the leader maps
  bool contribute = true;     ///< off: the followers only localise (the baseline)
  /// Added to every pose a follower claims (x, y metres, theta degrees; map frame): robots
  /// whose pose is wrong, to measure what the leader's checks catch.
  std::vector<double> claim_offset = {0.0, 0.0, 0.0};
  std::string png;  ///< the final map with the combined trajectory
  std::string output = "esfleet-bench-contribute.json";
  bool json = false;
  SlamConfig slam;
  LocaliserConfig localiser;
  ContributorConfig contributor;
  CarmenReaderOptions reader;
  app::ParamTable params;
};

void add_contribute_bench_options(CLI::App& cmd, ContributeBenchOptions& o);
int run_contribute_bench(ContributeBenchOptions& o);

}  // namespace esfleet::bench
