#pragma once
// esfleet-bench noisy-odometry: rewrites a log's odometry into noisy wheel odometry
// (core/odometry_noise.hpp), seeded, so the SLAM can be tried with odometry as real robots have
// it. The source motion is each scan's odometry field: in a corrected log (fr079, csail-corrected)
// the corrected poses, in a raw log its own (already noisy) odometry.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/odometry_noise.hpp"

namespace esfleet::bench {

struct NoisyOdometryOptions {
  std::string log;      ///< CARMEN log to read
  std::string out_dir;  ///< writes <out_dir>/<robot_id>.log and .truth
  std::string robot_id = "noisy";
  std::uint64_t seed = 1;
  OdometryNoise noise;
  CarmenReaderOptions reader;
  std::string json;  ///< write the figures here too (empty: not)
};

/// --log, --out-dir, --robot-id, --seed, the noise parameters, --even-beams, --json.
void add_noisy_odometry_options(CLI::App& cmd, NoisyOdometryOptions& o);
/// Writes the log with noisy odometry (esfleet-sim's log format: an ODOM line, then the laser
/// line with the noisy odometry in its pose fields) and <robot_id>.truth with the source poses
/// (for evaluation only); prints the distance driven and the drift. Returns the exit code.
int run_noisy_odometry(const NoisyOdometryOptions& o);

}  // namespace esfleet::bench
