#pragma once
#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "app/param_table.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/localiser.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet::bench {

struct LocaliseBenchOptions {
  std::string log;
  std::string which = "both";  ///< a (map from the whole log), b (first half), both
  int starts = 100;            ///< seeded starts per case
  /// Run exactly these start scans instead of drawing (to study single starts); each keeps the
  /// localiser seed of its place in the list.
  std::vector<std::size_t> start_scans;
  int budget = 700;  ///< scans a start may use before it counts as not localised
  /// Also report the rates as if the budget were each of these (the same runs, cut short).
  std::vector<int> within = {100, 300};
  std::uint64_t seed = 1;
  int kidnaps = 20;
  int threads = 1;
  std::string relations;  ///< ground-truth relations for the tracking error (evaluation only)
  double time_offset = 0.0;
  std::string output = "esfleet-bench-localise.json";
  bool json = false;
  /// Per-scan trace of every start that did not declare the right pose (diagnostics).
  std::string trace;
  bool trace_all = false;  ///< the trace holds the right starts too
  /// The leader's use of odometry: "same" as the followers' (--odometry), "on" or "off" (a
  /// laser-only map with followers that read their odometry, or the other way round).
  std::string leader_odometry = "same";
  /// The leader's SLAM (the SLAM flags); the followers track with its tracking part.
  SlamConfig slam;
  /// The followers' localiser; its tracking part is copied from `slam` once the flags are read.
  LocaliserConfig config;
  CarmenReaderOptions reader;
  app::ParamTable params;
};

void add_localise_bench_options(CLI::App& cmd, LocaliseBenchOptions& o);
int run_localise_bench(LocaliseBenchOptions& o);

}  // namespace esfleet::bench
