// esfleet-bench: benchmark programs that print figures and write them to a file.
//   slam      per-scan cost of the SLAM on a recorded log: the ES search and the map update
//             separately, the paper's configuration and ours, in one process.
//   localise  follower global localisation in a leader's map built from the same log: success,
//             wrong-confident rate and CPU time to a declared pose; tracking error; kidnap.
//   occupancy the cells of a saved map.yaml (as map_server reads it) and where the leader's own
//             scans end in it: on occupied, free or unknown cells.
//   occupancy-truth  a simulated run's map against the world's true walls: precision, recall.
//   noisy-odometry  a log rewritten with noisy wheel odometry (seeded), for the SLAM to use.
//   generalise  the SLAM on sparse scans: the CSAIL key-scan log, CSAIL and fr079 subsampled,
//             laser only and with noisy odometry, scored on relations over seeds.
#include <malloc.h>

#include "app/program.hpp"
#include "contribute_bench.hpp"
#include "generalise.hpp"
#include "localise_bench.hpp"
#include "noisy_odometry.hpp"
#include "occupancy_bench.hpp"
#include "slam_bench.hpp"

int main(int argc, char** argv) {
  using namespace esfleet;
  mallopt(M_ARENA_MAX, 1);  // as esfleet-leader: its peak RSS is what `slam` reports
  app::Program program(
      "esfleet-bench", "bench",
      "esfleet-bench: speed and accuracy benchmarks (figures on stdout and in a file)");
  CLI::App& cli = program.cli();
  cli.require_subcommand(1);
  bench::SlamBenchOptions slam;
  CLI::App* slam_cmd = cli.add_subcommand(
      "slam",
      "ms per scan of the ES search (paper parameters mu=100, T=1000) and of the map update, "
      "for the paper's configuration and for esfleet's default pipeline, on a CARMEN log");
  bench::add_slam_bench_options(*slam_cmd, slam);
  bench::LocaliseBenchOptions localise;
  CLI::App* localise_cmd = cli.add_subcommand(
      "localise",
      "follower global localisation (no hint) in the leader's map of a CARMEN log, from seeded "
      "start scans of the same log: success and wrong-confident rates, CPU time and scans to "
      "a declared pose; tracking error over the log; kidnapped-robot recovery");
  bench::add_localise_bench_options(*localise_cmd, localise);
  bench::OccupancyBenchOptions occupancy;
  CLI::App* occupancy_cmd = cli.add_subcommand(
      "occupancy",
      "a saved map.yaml read as map_server reads it: its occupied, free and unknown cells, and "
      "the share of the scan end points of a CARMEN log, at the leader's own trajectory, that "
      "land on each (no ground truth)");
  bench::add_occupancy_bench_options(*occupancy_cmd, occupancy);
  bench::OccupancyBenchOptions truth;
  CLI::App* truth_cmd = cli.add_subcommand(
      "occupancy-truth",
      "a map.yaml of an esfleet-sim run against the world's true walls: precision (occupied "
      "cells within a cell of a true wall) and recall (true wall cells the beams hit with an "
      "occupied cell within a cell), the map aligned by the leader's and the true trajectory");
  bench::add_occupancy_truth_options(*truth_cmd, truth);
  bench::NoisyOdometryOptions noisy;
  CLI::App* noisy_cmd = cli.add_subcommand(
      "noisy-odometry",
      "rewrite a CARMEN log's odometry as noisy wheel odometry (seeded; drift grows with the "
      "distance driven and the angle turned), writing OUT_DIR/ROBOT_ID.log and .truth");
  bench::add_noisy_odometry_options(*noisy_cmd, noisy);
  bench::GeneraliseOptions generalise;
  CLI::App* generalise_cmd = cli.add_subcommand(
      "generalise",
      "the SLAM on sparse scans: the MIT CSAIL key-scan log (406 scans), CSAIL and fr079 kept "
      "every k-th scan, laser only and with noisy odometry, over seeds; scored on the relations "
      "whose both ends are kept and on relations derived from the reference poses (evaluation "
      "only), with the floor of that score where the run on every scan of the log is in the "
      "set; one JSON file and two markdown tables (per log and k; per gap of the derived "
      "relations)");
  bench::add_generalise_options(*generalise_cmd, generalise);
  bench::ContributeBenchOptions contribute;
  CLI::App* contribute_cmd = cli.add_subcommand(
      "contribute",
      "mapping together: the leader maps the first half of a CARMEN log, followers run the "
      "second half from case (b) starts, localise with no hint and contribute their scans; the "
      "final map's coverage of the whole-log map and the trajectories' relations error "
      "(evaluation only)");
  bench::add_contribute_bench_options(*contribute_cmd, contribute);
  if (auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    if (slam_cmd->parsed()) return bench::run_slam_bench(slam);
    if (localise_cmd->parsed()) return bench::run_localise_bench(localise);
    if (occupancy_cmd->parsed()) return bench::run_occupancy_bench(occupancy);
    if (truth_cmd->parsed()) return bench::run_occupancy_truth(truth);
    if (noisy_cmd->parsed()) return bench::run_noisy_odometry(noisy);
    if (generalise_cmd->parsed()) return bench::run_generalise(generalise);
    if (contribute_cmd->parsed()) return bench::run_contribute_bench(contribute);
    return static_cast<int>(app::kExitUsage);  // require_subcommand(1): not reached
  });
}
