#pragma once
// esfleet-bench occupancy: how a saved map (map.yaml, read as map_server reads it) classifies
// the cells the SLAM's own scans end in. esfleet-bench occupancy-truth: the map's occupied
// cells against a simulated world's true walls (precision and recall). docs/slam.md, "Map
// files".
#include <CLI/CLI.hpp>
#include <string>

#include "app/param_table.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet::bench {

struct OccupancyBenchOptions {
  std::string log;         ///< CARMEN log the map was built from
  std::string trajectory;  ///< the leader's trajectory.txt: one pose per scan of the log
  std::string map;         ///< map.yaml, loaded with load_ros_map
  std::string json;        ///< write the figures here too (empty: not)
  // occupancy-truth only (evaluation: the world and the true poses of a simulated run).
  std::string truth;  ///< esfleet-sim's <id>.truth
  std::string world;  ///< the world map.yaml esfleet-sim drove in
  /// The leader's SLAM flags: the reader's and the beam range ones decide the end points.
  SlamConfig slam;
  CarmenReaderOptions reader;
  app::ParamTable params;
};

/// esfleet-bench occupancy: --log, --trajectory, --map, optional --json, the SLAM flags.
void add_occupancy_bench_options(CLI::App& cmd, OccupancyBenchOptions& o);
int run_occupancy_bench(OccupancyBenchOptions& o);

/// esfleet-bench occupancy-truth: the same plus --truth and --world.
void add_occupancy_truth_options(CLI::App& cmd, OccupancyBenchOptions& o);
int run_occupancy_truth(OccupancyBenchOptions& o);

}  // namespace esfleet::bench
