#pragma once
// esfleet-bench generalise: how the SLAM, tuned on two dense logs, holds on sparse scans. It runs
// the SLAM over the MIT CSAIL key-scan log (406 scans), the raw CSAIL log and fr079 kept every
// k-th scan, laser only and with noisy odometry, over several seeds, and scores each run on the
// Kümmerle relations whose both ends were kept and on relations derived from the reference poses
// (docs/benchmarks.md, "Generalisation"); optionally over simulated key-scan-like logs whose
// reference is the simulation's truth. One JSON file, one markdown table on stdout.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "app/param_table.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/odometry_noise.hpp"
#include "esfleet/core/slam.hpp"
#include "esfleet/sim/laser_model.hpp"
#include "esfleet/sim/robot.hpp"

namespace esfleet::bench {

struct GeneraliseOptions {
  std::string data_dir = "data";  ///< holds mit-csail/ and fr079/ as in the repository
  std::vector<std::string> logs = {"csail-keys", "csail", "fr079"};
  /// Every k-th scan of the raw logs; empty: CSAIL 1-5, fr079 1, 2, 4, 6, 8. The key-scan log
  /// always runs whole (k = 1).
  std::vector<std::size_t> ks;
  std::vector<std::string> modes = {"laser", "odom"};
  std::string seeds = "1-5";
  /// The simulated logs (--logs sim, sim-fr079): one per simulation seed, each duration_s of a
  /// robot scanning sim_rate times a second (once: a key-scan log) in the MIT CSAIL or the
  /// Freiburg 079 world, scored against its true poses.
  std::string sim_seeds = "1-4";
  double sim_duration_s = 400.0;
  double sim_rate = 1.0;
  /// The simulated robot's motion and laser (--sim-speed etc.: harder conditions than the
  /// default 1 m/s, 60 deg/s, 30 m, 1 cm noise). Its clearance is the world's unless
  /// sim_clearance >= 0.
  sim::MotionConfig sim_motion{.speed = 1.0};
  sim::LaserConfig sim_laser;
  double sim_clearance = -1.0;
  std::size_t max_scans = 0;  ///< at most this many scans per run, after subsampling (0 = all)
  std::size_t beam_step = 1;  ///< every run's scans keep every beam_step-th beam (keep_every_beam)
  int jobs = 1;               ///< runs in parallel (the scores do not depend on it)
  std::string output = "esfleet-bench-generalise.json";
  /// When set, each run's estimate beside its reference poses goes to a text file in it.
  std::string trajectories;
  bool paper = false;  ///< start from SlamConfig::paper() before the SLAM flags
  OdometryNoise noise;
  SlamConfig config;  ///< every run's SLAM; mode and seed set per run
  CarmenReaderOptions reader;
  app::ParamTable params;
};

void add_generalise_options(CLI::App& cmd, GeneraliseOptions& o);
/// Runs every (log, k, mode, seed), writes the JSON, prints the table; the exit code.
int run_generalise(GeneraliseOptions& o);

}  // namespace esfleet::bench
