// esfleet-bench: benchmark programs that print figures and write them to a file.
//   slam      per-scan cost of the SLAM on a recorded log: the ES search and the map update
//             separately, the paper's configuration and ours, in one process.
//   localise  follower global localisation in a leader's map built from the same log: success,
//             wrong-confident rate and CPU time to a declared pose; tracking error; kidnap.
#include "app/program.hpp"
#include "localise_bench.hpp"
#include "slam_bench.hpp"

int main(int argc, char** argv) {
  using namespace esfleet;
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
  if (auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    if (slam_cmd->parsed()) return bench::run_slam_bench(slam);
    if (localise_cmd->parsed()) return bench::run_localise_bench(localise);
    return static_cast<int>(app::kExitUsage);  // require_subcommand(1): not reached
  });
}
