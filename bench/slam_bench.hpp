#pragma once
#include <CLI/CLI.hpp>
#include <string>

#include "app/param_table.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet::bench {

struct SlamBenchOptions {
  std::string log;
  std::size_t max_scans = 0;
  int repeats = 1;
  std::string output = "esfleet-bench-slam.json";
  bool json = false;
  bool skip_default = false;
  bool skip_paper = false;
  SlamConfig config;  ///< "default" run: esfleet's pipeline, flags may change it
  CarmenReaderOptions reader;
  app::ParamTable params;
};

void add_slam_bench_options(CLI::App& cmd, SlamBenchOptions& o);
int run_slam_bench(SlamBenchOptions& o);

}  // namespace esfleet::bench
