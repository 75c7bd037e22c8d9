#include "slam_bench.hpp"

#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "app/slam_params.hpp"
#include "app/summary.hpp"
#include "esfleet/core/file_io.hpp"

namespace esfleet::bench {

void add_slam_bench_options(CLI::App& cmd, SlamBenchOptions& o) {
  cmd.add_option("--log", o.log, "CARMEN log")->required();
  cmd.add_option("--max-scans", o.max_scans, "use the first N scans (0 = all)")
      ->capture_default_str();
  cmd.add_option("--repeats", o.repeats, "runs per configuration; medians over all scans")
      ->capture_default_str();
  cmd.add_option("--output", o.output, "JSON file for the figures")->capture_default_str();
  cmd.add_flag("--json", o.json, "last line of stdout is the JSON object");
  cmd.add_flag("--paper-only", o.skip_default, "benchmark only the paper's configuration");
  cmd.add_flag("--default-only", o.skip_paper, "benchmark only the default pipeline")
      ->excludes("--paper-only");
  app::add_slam_params(o.params, &o.config, &o.reader);
  o.params.bind(cmd, "Parameters of the default run");
}

namespace {

struct RunFigures {
  app::Summary search, update, loop, total;
  std::size_t scans = 0;
  std::size_t loops = 0;
  double evaluations_per_s = 0.0;
};

RunFigures run_config(const SlamConfig& config, const std::vector<LaserScan>& scans, int repeats) {
  std::vector<double> search, update, loop, total;
  RunFigures f;
  for (int r = 0; r < repeats; ++r) {
    Slam slam(config);
    for (const LaserScan& scan : scans) {
      const auto t0 = std::chrono::steady_clock::now();
      const SlamStep step = slam.process(scan);
      total.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      if (slam.scans_processed() == 1) continue;  // the first scan is only inserted
      search.push_back(step.search_ms);
      if (step.inserted) update.push_back(step.update_ms);
      loop.push_back(step.loop_ms);
    }
    f.loops = slam.loop_closures();
  }
  f.scans = scans.size();
  f.search = app::summarize(search);
  f.update = app::summarize(update);
  f.loop = app::summarize(loop);
  f.total = app::summarize(total);
  const double evals = static_cast<double>(config.tracking.es.mu + config.tracking.es.iterations);
  f.evaluations_per_s = f.search.median > 0 ? evals / (f.search.median * 1e-3) : 0.0;
  return f;
}

nlohmann::json to_json(const RunFigures& f) {
  auto s = [](const app::Summary& x) {
    return nlohmann::json{{"median", x.median}, {"p95", x.p95}, {"max", x.max}, {"mean", x.mean}};
  };
  return {{"scans", f.scans},
          {"search_ms", s(f.search)},
          {"update_ms", s(f.update)},
          {"loop_ms", s(f.loop)},
          {"total_ms", s(f.total)},
          {"loop_closures", f.loops},
          {"es_evaluations_per_s_at_median", f.evaluations_per_s}};
}

void print(const char* name, const RunFigures& f) {
  std::printf(
      "%-8s search %6.3f ms median  %6.3f p95 | update %6.3f median  %6.3f p95 | "
      "total %6.3f median  %6.3f p95  %7.3f max\n",
      name, f.search.median, f.search.p95, f.update.median, f.update.p95, f.total.median,
      f.total.p95, f.total.max);
}

}  // namespace

int run_slam_bench(SlamBenchOptions& o) {
  std::vector<LaserScan> scans;
  try {
    o.params.apply();
    o.config.validate();
    scans = read_carmen_log(o.log, o.reader, o.max_scans);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "esfleet-bench slam: %s\n", e.what());
    return 2;
  }
  std::fprintf(stderr, "%s: %zu scans, %d repeat(s)\n", o.log.c_str(), scans.size(), o.repeats);
  nlohmann::json j;
  j["log"] = o.log;
  j["scans"] = scans.size();
  RunFigures fp;
  if (!o.skip_paper) {
    fp = run_config(SlamConfig::paper(), scans, o.repeats);
    print("paper", fp);
    j["paper"] = to_json(fp);
    j["paper"]["process_peak_rss_mb"] = app::peak_rss_mb();
  }
  if (!o.skip_default) {
    const RunFigures fd = run_config(o.config, scans, o.repeats);
    print("default", fd);
    j["default"] = to_json(fd);
    // The whole process so far (all scans held in memory, the paper run before it): the
    // leader's own figure is peak_rss_mb in its stats.json.
    j["default"]["process_peak_rss_mb"] = app::peak_rss_mb();
    if (!o.skip_paper) {
      j["default_over_paper_search_median"] =
          fp.search.median > 0 ? fd.search.median / fp.search.median : 0.0;
      j["default_total_over_paper_search_median"] =
          fp.search.median > 0 ? fd.total.median / fp.search.median : 0.0;
      std::printf(
          "default/paper search median ratio %.2f, default whole step / paper search %.2f\n",
          j["default_over_paper_search_median"].get<double>(),
          j["default_total_over_paper_search_median"].get<double>());
    }
  }
  try {
    write_file_atomically(o.output, j.dump(2) + "\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "esfleet-bench slam: %s\n", e.what());
    return 1;
  }
  std::printf("peak RSS of this process %.1f MB\n", app::peak_rss_mb());
  if (o.json) std::printf("%s\n", j.dump().c_str());
  return 0;
}

}  // namespace esfleet::bench
