#include "localise_bench.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>

#include "app/localise_params.hpp"
#include "app/slam_params.hpp"
#include "app/summary.hpp"
#include "bench_maps.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/core/fitness.hpp"
#include "esfleet/core/relations.hpp"
#include "esfleet/core/scan_points.hpp"
#include "esfleet/core/slam.hpp"
#include "parallel_for.hpp"

namespace esfleet::bench {

void add_localise_bench_options(CLI::App& cmd, LocaliseBenchOptions& o) {
  cmd.add_option("--log", o.log, "CARMEN log (the leader maps it, followers take scans from it)")
      ->required();
  cmd.add_option("--case", o.which,
                 "a: map from the whole log, starts across it; b: map from the first half, "
                 "starts in the second half where it was mapped; both")
      ->check(CLI::IsMember({"a", "b", "both"}))
      ->capture_default_str();
  cmd.add_option("--starts", o.starts, "seeded starts per case")->capture_default_str();
  cmd.add_option("--start-scans", o.start_scans,
                 "run these start scans (comma-separated) instead of drawing --starts (the "
                 "coverage check of case b is not applied)")
      ->delimiter(',');
  cmd.add_option("--budget", o.budget, "scans a start may use before it counts as not localised")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd.add_option("--within", o.within,
                 "also report success and wrong rates within each of these many scans "
                 "(comma-separated; the same runs cut short)")
      ->delimiter(',')
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  cmd.add_option("--bench-seed", o.seed, "seed of the start sampling and the localisers")
      ->capture_default_str();
  cmd.add_option("--kidnaps", o.kidnaps, "kidnapped-robot trials (case a map)")
      ->capture_default_str();
  cmd.add_option("--threads", o.threads, "starts run in parallel (CPU time is per thread)")
      ->capture_default_str();
  cmd.add_option("--relations", o.relations,
                 "relations file: tracking error of a follower run over the whole log");
  cmd.add_option("--time-offset", o.time_offset, "relation stamp = trajectory stamp + this")
      ->capture_default_str();
  cmd.add_option("--output", o.output, "JSON file for the figures")->capture_default_str();
  cmd.add_flag("--json", o.json, "last line of stdout is the JSON object");
  cmd.add_option("--trace", o.trace,
                 "write a per-scan trace of every failed start to this file (the leading "
                 "hypothesis, the one nearest the reference, their scores and errors)");
  cmd.add_flag("--trace-all", o.trace_all,
               "--trace writes every start, the right ones too (to study the declaration rule)");
  cmd.add_option("--leader-odometry", o.leader_odometry,
                 "the leader's SLAM with odometry: same as the followers' (--odometry), on or off")
      ->check(CLI::IsMember({"same", "on", "off"}))
      ->capture_default_str();
  app::add_slam_params(o.params, &o.slam, &o.reader);
  app::add_localise_params(o.params, &o.config);
  o.params.bind(cmd, "Parameters (leader SLAM and follower)");
}

namespace {

struct PoseError {
  double xy = 0.0, theta_deg = 0.0;
};
PoseError pose_error(const Pose2& p, const Pose2& truth) {
  return {std::hypot(p.x - truth.x, p.y - truth.y),
          rad_to_deg(std::abs(normalize_angle(p.theta - truth.theta)))};
}

bool within(const Pose2& a, const Pose2& b, double xy, double theta_deg) {
  return std::hypot(a.x - b.x, a.y - b.y) <= xy &&
         std::abs(normalize_angle(a.theta - b.theta)) <= deg_to_rad(theta_deg);
}

constexpr double kTolXy = 0.3;
/// Case b: scans from the start that must lie in the half map's known space.
constexpr std::size_t kCoveredScans = 20;
/// Starts are drawn from all but the last kDrawTail scans whatever the budget, so runs with
/// different budgets use the same starts (a start near the end stops at the end of the log).
constexpr std::size_t kDrawTail = 100;
constexpr double kTolThetaDeg = 5.0;

struct StartResult {
  std::size_t start = 0;
  bool declared = false;
  bool correct = false;
  int scans = 0;
  std::size_t declared_scan = 0;  ///< the scan the pose was declared at (if declared)
  double cpu_s = 0.0;
  double log_s = 0.0;
  double error_xy = 0.0, error_theta_deg = 0.0;
  /// How well the map agrees with the start scan at its reference pose (FitnessValue
  /// agreement): low where the map is wrong or the place changed, not the localiser's doing.
  float reference_agreement = 0.0f;
  /// Case b: distance from the start's reference to the nearest pose of the leader's path
  /// while it made the half map (how far the leader itself had been from here); -1 in case a.
  double path_distance = -1.0;
  std::string trace;  ///< per-scan lines (only with --trace)
  /// --trace: the grid searches of this start, and the stage where the reference fell out
  /// (not among the coarse poses kept, ranked below the candidates, or a candidate).
  int searches = 0, lost_coarse = 0, lost_ranking = 0, found = 0;
};

/// --trace: a search pose is "at the reference" within this (the candidates' own spacing is
/// 0.5 m and 10 deg; the ES refinement and the hypotheses pull in from there).
constexpr double kSearchNearXy = 1.0;
constexpr double kSearchNearThetaDeg = 10.0;

/// Index of the first pose within kSearchNear* of `truth`, -1 if none.
int rank_near(const std::vector<Pose2>& poses, const Pose2& truth) {
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (within(poses[i], truth, kSearchNearXy, kSearchNearThetaDeg)) return static_cast<int>(i);
  }
  return -1;
}

/// --trace: where the reference stood in the last grid search; counts it into `r`.
std::string trace_search(const SearchStages& st, const Pose2& truth, StartResult& r,
                         float truth_coarse) {
  const int coarse = rank_near(st.coarse, truth);
  const int ranked = rank_near(st.ranked, truth);
  const int cand = rank_near(st.candidates, truth);
  ++r.searches;
  if (cand >= 0) {
    ++r.found;
  } else if (coarse < 0) {
    ++r.lost_coarse;
  } else {
    ++r.lost_ranking;
  }
  // The sample position nearest the reference and how its coarse score ranks among all.
  double near_d = 1e18;
  float near_score = 0.0f;
  for (std::size_t i = 0; i < st.samples.size(); ++i) {
    const double d = std::hypot(st.samples[i].x - truth.x, st.samples[i].y - truth.y);
    if (d < near_d) {
      near_d = d;
      near_score = st.sample_score[i];
    }
  }
  std::size_t above = 0, above_truth = 0;
  for (const float f : st.sample_score) {
    above += f > near_score ? 1 : 0;
    above_truth += f > truth_coarse ? 1 : 0;
  }
  const double last =
      st.candidate_evidence.empty() ? 0.0 : static_cast<double>(st.candidate_evidence.back());
  char buf[384];
  std::snprintf(
      buf, sizeof buf,
      "    search: reference at coarse rank %d of %zu, re-ranked %d (evidence %.3f; "
      "last candidate %.3f), candidate %d; nearest sample %.2f m, coarse score rank %zu of %zu "
      "(%.2f; at the reference %.2f, rank %zu)\n",
      coarse, st.coarse.size(), ranked,
      ranked >= 0 ? static_cast<double>(st.ranked_evidence[static_cast<std::size_t>(ranked)]) : 0.0,
      last, cand, near_d, above, st.samples.size(), static_cast<double>(near_score),
      static_cast<double>(truth_coarse), above_truth);
  return buf;
}

/// Starts whose scan agrees with the map at the reference at least this much count as
/// "the map agrees" in the summary.
constexpr float kMapAgrees = 0.7f;
/// Case b starts within this distance of the leader's first-half path count as "the leader
/// drove here" in the summary (the rest lie in places the half map saw from a distance).
constexpr double kNearPath = 1.0;

/// The reference pose of scan i in the frame of the map being localised in.
using Reference = std::function<Pose2(std::size_t)>;

/// One trace line: the leading hypothesis and the one nearest the reference.
std::string trace_line(std::size_t scan, const LocaliserStep& step,
                       const std::vector<HypothesisView>& hyps, const Pose2& truth) {
  char buf[512];
  const PoseError lead = pose_error(step.pose, truth);
  int n =
      std::snprintf(buf, sizeof buf,
                    "  scan %zu %s%s hyps %zu lead err %.2f m %.1f deg agr %.2f known %.2f "
                    "ev %.3f",
                    scan, to_string(step.state), step.global_search ? " G" : "", step.hypotheses,
                    lead.xy, lead.theta_deg, static_cast<double>(step.value.agreement()),
                    step.value.known_share(), static_cast<double>(step.score));
  float top = 0.0f, second = 0.0f;
  const HypothesisView* near = nullptr;
  const HypothesisView* leader = nullptr;
  double near_d = 1e9;
  for (const auto& h : hyps) {
    if (h.score > top) {
      second = top;
      top = h.score;
      leader = &h;
    } else {
      second = std::max(second, h.score);
    }
    const PoseError e = pose_error(h.pose, truth);
    if (e.xy + e.theta_deg / 10.0 < near_d) {
      near_d = e.xy + e.theta_deg / 10.0;
      near = &h;
    }
  }
  n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n), " rival %.2f",
                     top > 0.0f ? static_cast<double>(second / top) : 0.0);
  if (leader != nullptr) {
    n += std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n),
                       " lead streak %d travel %.2f", leader->good_streak, leader->travel);
  }
  if (near != nullptr) {
    const PoseError e = pose_error(near->pose, truth);
    std::snprintf(buf + n, sizeof buf - static_cast<std::size_t>(n),
                  " | nearest err %.2f m %.1f deg score %.3f streak %d agr %.2f known %.2f "
                  "travel %.2f",
                  e.xy, e.theta_deg, static_cast<double>(near->score), near->good_streak,
                  static_cast<double>(near->value.agreement()), near->value.known_share(),
                  near->travel);
  }
  return std::string(buf) + "\n";
}

/// --trace-all: every hypothesis of the pool, "id:error m:error deg:hits:known:points".
std::string trace_hypotheses(const std::vector<HypothesisView>& hyps, const Pose2& truth) {
  std::string out = "    pool";
  char buf[96];
  for (const auto& h : hyps) {
    const PoseError e = pose_error(h.pose, truth);
    std::snprintf(buf, sizeof buf, " %u:%.2f:%.1f:%d:%d:%d", h.id, e.xy, e.theta_deg, h.value.n_hit,
                  h.value.n_known, h.value.n_points);
    out += buf;
  }
  return out + "\n";
}

/// --trace: what the localiser of a start reports (the last global search's stages, the
/// hypotheses after the last scan).
class TraceObserver : public LocaliserObserver {
 public:
  bool wants_search_stages() const override { return true; }
  void on_search_stages(const SearchStages& stages) override { last_search_ = stages; }
  void on_scan(const LocaliserStep& /*step*/,
               const std::vector<HypothesisView>& hypotheses) override {
    hypotheses_ = hypotheses;
  }
  const SearchStages& last_search() const { return last_search_; }
  const std::vector<HypothesisView>& hypotheses() const { return hypotheses_; }

 private:
  SearchStages last_search_;
  std::vector<HypothesisView> hypotheses_;
};

StartResult run_start(const LocaliserConfig& config, const GridMap& map,
                      const std::vector<LaserScan>& scans, const Reference& ref, std::size_t start,
                      int budget, bool trace, bool trace_all) {
  Localiser loc(config);
  TraceObserver observer;
  if (trace) loc.set_observer(&observer);
  StartResult r;
  r.start = start;
  double cpu_ms = 0.0;
  for (std::size_t j = start; j < scans.size() && r.scans < budget; ++j) {
    const LocaliserStep step = loc.process(map, scans[j]);
    cpu_ms += step.cpu_ms;
    ++r.scans;
    if (trace) {
      r.trace += trace_line(j, step, observer.hypotheses(), ref(j));
      if (trace_all) r.trace += trace_hypotheses(observer.hypotheses(), ref(j));
      // (the ES search, --localise-search es, records no stages)
      const SearchStages& st = observer.last_search();
      if (step.global_search && !st.coarse.empty()) {
        // The coarse score at the reference itself, as the grid search scores its samples.
        const ScanPoints pts = prepare_scan(scans[j], config.tracking);
        const float truth_coarse = FitnessEvaluator(map, pts, st.coarse_options).fitness(ref(j));
        r.trace += trace_search(st, ref(j), r, truth_coarse);
      }
    }
    if (step.declared) {
      r.declared = true;
      const Pose2 truth = ref(j);
      r.declared_scan = j;
      r.correct = within(step.pose, truth, kTolXy, kTolThetaDeg);
      const PoseError e = pose_error(step.pose, truth);
      r.error_xy = e.xy;
      r.error_theta_deg = e.theta_deg;
      r.log_s = scans[j].stamp - scans[start].stamp;
      break;
    }
  }
  r.cpu_s = cpu_ms * 1e-3;
  return r;
}

nlohmann::json summarize_case(const std::vector<StartResult>& results, std::size_t skipped,
                              int budget, const std::vector<int>& within) {
  std::vector<double> cpu, log_s, scans;
  std::size_t ok = 0, wrong = 0, agree = 0, agree_ok = 0, agree_wrong = 0;
  std::vector<std::size_t> within_ok(within.size(), 0), within_wrong(within.size(), 0);
  std::size_t log_ended = 0;
  std::size_t near_path = 0, near_ok = 0, near_wrong = 0;
  nlohmann::json failures = nlohmann::json::array();
  for (const StartResult& r : results) {
    if (r.reference_agreement >= kMapAgrees) {
      ++agree;
      if (r.declared) (r.correct ? agree_ok : agree_wrong)++;
    }
    if (r.path_distance >= 0.0 && r.path_distance <= kNearPath) {
      ++near_path;
      if (r.declared) (r.correct ? near_ok : near_wrong)++;
    }
    if (r.declared) {
      cpu.push_back(r.cpu_s);
      log_s.push_back(r.log_s);
      scans.push_back(r.scans);
      (r.correct ? ok : wrong)++;
      // The localiser does not know the budget: a shorter one only cuts the same run.
      for (std::size_t w = 0; w < within.size(); ++w) {
        if (r.scans <= within[w]) (r.correct ? within_ok[w] : within_wrong[w])++;
      }
    }
    if (!r.declared && r.scans < budget) ++log_ended;
    if (!r.correct) {
      failures.push_back({{"start_scan", r.start},
                          {"declared", r.declared},
                          {"error_m", r.error_xy},
                          {"error_deg", r.error_theta_deg},
                          {"scans", r.scans},
                          {"reference_agreement", r.reference_agreement},
                          {"leader_path_distance_m", r.path_distance}});
    }
  }
  /// k of d as a share (0 when d is 0).
  const auto rate = [](std::size_t k, std::size_t d) {
    return static_cast<double>(k) / static_cast<double>(std::max<std::size_t>(1, d));
  };
  const std::size_t n = results.size();
  const app::Summary c = app::summarize(cpu), l = app::summarize(log_s), s = app::summarize(scans);
  nlohmann::json cut = nlohmann::json::array();
  for (std::size_t w = 0; w < within.size(); ++w) {
    cut.push_back({{"scans", within[w]},
                   {"success_rate", rate(within_ok[w], n)},
                   {"wrong_rate", rate(within_wrong[w], n)}});
  }
  return {{"starts", results.size()},
          {"skipped_unmapped_starts", skipped},
          {"success_rate", rate(ok, n)},
          {"wrong_rate", rate(wrong, n)},
          {"undeclared_rate", rate(n - ok - wrong, n)},
          {"median_s", c.median},
          {"p95_s", c.p95},
          {"max_s", c.max},
          {"log_time_median_s", l.median},
          {"log_time_p95_s", l.p95},
          {"scans_median", s.median},
          {"scans_p95", s.p95},
          {"undeclared_log_ended", log_ended},
          {"within", cut},
          {"starts_where_map_agrees", agree},
          {"success_rate_where_map_agrees", rate(agree_ok, agree)},
          {"wrong_rate_where_map_agrees", rate(agree_wrong, agree)},
          {"starts_near_leader_path", near_path},
          {"success_rate_near_leader_path", rate(near_ok, near_path)},
          {"wrong_rate_near_leader_path", rate(near_wrong, near_path)},
          {"failures", failures}};
}

void print_case(const char* name, const nlohmann::json& j) {
  std::printf(
      "case %s: %d starts: success %.1f %%, wrong %.1f %%, undeclared %.1f %% | CPU to a pose: "
      "median %.3f s, p95 %.3f s, max %.3f s | log time median %.1f s | scans median %.0f, p95 "
      "%.0f\n",
      name, j["starts"].get<int>(), 100.0 * j["success_rate"].get<double>(),
      100.0 * j["wrong_rate"].get<double>(), 100.0 * j["undeclared_rate"].get<double>(),
      j["median_s"].get<double>(), j["p95_s"].get<double>(), j["max_s"].get<double>(),
      j["log_time_median_s"].get<double>(), j["scans_median"].get<double>(),
      j["scans_p95"].get<double>());
  for (const nlohmann::json& w : j["within"]) {
    std::printf("  within %d scans: success %.1f %%, wrong %.1f %%\n", w["scans"].get<int>(),
                100.0 * w["success_rate"].get<double>(), 100.0 * w["wrong_rate"].get<double>());
  }
  if (j["undeclared_log_ended"].get<int>() > 0) {
    std::printf("  undeclared when the log ended (before the budget): %d starts\n",
                j["undeclared_log_ended"].get<int>());
  }
  std::printf(
      "  where the map agrees with the start scan at its reference (agreement >= %.1f): "
      "%d starts, success %.1f %%, wrong %.1f %%\n",
      static_cast<double>(kMapAgrees), j["starts_where_map_agrees"].get<int>(),
      100.0 * j["success_rate_where_map_agrees"].get<double>(),
      100.0 * j["wrong_rate_where_map_agrees"].get<double>());
  if (j["starts_near_leader_path"].get<int>() > 0) {
    std::printf(
        "  where the leader drove within %.1f m while making the map: %d starts, success %.1f "
        "%%, wrong %.1f %%\n",
        kNearPath, j["starts_near_leader_path"].get<int>(),
        100.0 * j["success_rate_near_leader_path"].get<double>(),
        100.0 * j["wrong_rate_near_leader_path"].get<double>());
  }
  std::fflush(stdout);
}

/// Reads the parameters and the log and checks the options against it; 0 on success, else the
/// exit code (2) after printing why.
int load_log(LocaliseBenchOptions& o, std::vector<LaserScan>& scans) {
  try {
    o.params.apply();
    o.config.tracking = o.slam.tracking;
    o.slam.validate();
    o.config.validate();
    scans = read_carmen_log(o.log, o.reader);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "esfleet-bench localise: %s\n", e.what());
    return 2;
  }
  if (scans.size() < 2 * kDrawTail + 10) {
    std::fprintf(stderr, "esfleet-bench localise: %s has %zu scans, too few (at least %zu)\n",
                 o.log.c_str(), scans.size(), 2 * kDrawTail + 10);
    return 2;
  }
  for (const std::size_t s : o.start_scans) {
    if (s >= scans.size() || (o.which != "a" && s < scans.size() / 2)) {
      std::fprintf(stderr,
                   "esfleet-bench localise: --start-scans: scan %zu is outside the log's %s "
                   "(case b starts from scan %zu, the log has %zu)\n",
                   s, o.which == "a" ? "scans" : "second half", scans.size() / 2, scans.size());
      return 2;
    }
  }
  return 0;
}

/// What the leader's SLAM run over the whole log leaves the benchmark.
struct LeaderRun {
  bool odometry = false;  ///< whether the leader used odometry
  std::size_t half = 0;   ///< scans in the half map (case b)
  GridMap half_map;       ///< the map as it was after `half` scans
  GridMap full_map;       ///< the map after the whole log
  /// Reference poses: the leader's final trajectory (read only by this benchmark).
  std::vector<TimedPose> ref;
};

/// The leader: one SLAM run over the whole log; the map as it was at half time is kept. Both
/// maps get the coarse levels the localiser needs (what a follower rebuilds).
LeaderRun map_log(const LocaliseBenchOptions& o, const std::vector<LaserScan>& scans) {
  std::fprintf(stderr, "%s: %zu scans; mapping (leader SLAM) ...\n", o.log.c_str(), scans.size());
  const int levels = o.config.search.coarse_level;
  SlamConfig leader_config = o.slam;
  if (o.leader_odometry != "same") leader_config.tracking.use_odometry = o.leader_odometry == "on";
  Slam slam(leader_config);
  LeaderRun run;
  run.odometry = leader_config.tracking.use_odometry;
  run.half = scans.size() / 2;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    slam.process(scans[i]);
    // The map as the mapping thread would have it: no loop-closure search left speculative.
    if (i + 1 == run.half) {
      slam.settle();
      run.half_map = copy_map(slam.map(), levels);
    }
    if ((i + 1) % (scans.size() / 10) == 0) {
      std::fprintf(stderr, "  %zu %%\n", 100 * (i + 1) / scans.size());
    }
  }
  slam.settle();
  run.full_map = copy_map(slam.map(), levels);
  run.ref = slam.trajectory();
  return run;
}

/// Case b's references. The leader's later loop closures moved its frame (up to ~0.4 m on
/// CSAIL) after the half map was taken, so a final pose may sit beside the wall it saw in the
/// half map. A second-half scan's reference in the half map is its final pose re-aligned by a
/// local scan match in the half map (evidence, within 0.5 m and 5 deg): evaluation only.
/// Computed once per scan; safe to call from several threads.
class HalfMapReferences {
 public:
  HalfMapReferences(const LeaderRun& leader, const std::vector<LaserScan>& scans,
                    const TrackingConfig& tracking)
      : leader_(leader), scans_(scans), tracking_(tracking), cache_(scans.size()) {}

  Pose2 operator()(std::size_t i) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (cache_[i]) return *cache_[i];
    }
    const ScanPoints pts = prepare_scan(scans_[i], tracking_);
    FitnessOptions fo;
    fo.interpolate = true;
    const FitnessEvaluator eval(leader_.half_map, pts, fo);
    const Pose2 r = leader_.ref[i].pose;
    const Pose2 best = best_evidence_near(eval, r, 0.5, 0.05, 5).pose;
    std::lock_guard<std::mutex> lock(mutex_);
    cache_[i] = best;
    return best;
  }

  /// How far the references of `used` (looked up before) were moved: the count moved more
  /// than 0.1 m, and the largest move.
  std::pair<std::size_t, double> realignment(const std::vector<std::size_t>& used) const {
    std::size_t realigned = 0;
    double realign_max = 0.0;
    for (const std::size_t i : used) {
      const double moved = pose_error(*cache_[i], leader_.ref[i].pose).xy;
      if (moved > 0.1) ++realigned;
      realign_max = std::max(realign_max, moved);
    }
    return {realigned, realign_max};
  }

 private:
  const LeaderRun& leader_;
  const std::vector<LaserScan>& scans_;
  const TrackingConfig& tracking_;
  std::vector<std::optional<Pose2>> cache_;
  std::mutex mutex_;
};

/// One case of the benchmark: the map the followers localise in and where their starts lie.
struct BenchCase {
  const char* name;  ///< "a" (whole-log map) or "b" (half map)
  const GridMap& map;
  std::size_t lo;              ///< first scan a start may be drawn from
  bool half;                   ///< case b: starts must lie where the half map covers them
  const Reference& reference;  ///< scan -> reference pose in `map`
};

/// The start scans of a case: --start-scans, or --starts draws from [lo, end - kDrawTail) with
/// the case's own stream, so a case's starts do not depend on which other cases run (--case a,
/// b or both give the same starts for a case). `skipped`: draws refused in case b.
std::vector<std::size_t> draw_starts(const LocaliseBenchOptions& o,
                                     const std::vector<LaserScan>& scans, const LeaderRun& leader,
                                     const BenchCase& bc, std::size_t& skipped) {
  Rng pick(o.seed * 1000u + static_cast<std::uint64_t>(bc.name[0]));
  std::vector<std::size_t> starts;
  skipped = 0;
  const std::size_t hi = scans.size() - kDrawTail;
  for (const std::size_t s : o.start_scans) {
    if (s >= bc.lo) starts.push_back(s);  // (checked before the leader ran)
  }
  while (o.start_scans.empty() && starts.size() < static_cast<std::size_t>(o.starts)) {
    const std::size_t s = bc.lo + pick.below(static_cast<std::uint32_t>(hi - bc.lo));
    // Case b: only starts where the robot is, and stays for its first kCoveredScans scans,
    // in what the half map covers (at each scan's final pose at least half of the end points
    // on known cells): a robot driving into unmapped space cannot be localised yet.
    if (bc.half) {
      bool covered = true;
      for (std::size_t j = s; j < s + kCoveredScans && j < scans.size() && covered; ++j) {
        const ScanPoints pts = prepare_scan(scans[j], o.config.tracking);
        const FitnessValue v = FitnessEvaluator(bc.map, pts).evaluate(leader.ref[j].pose);
        covered = v.n_points > 0 && 2 * v.n_known >= v.n_points;
      }
      if (!covered) {
        ++skipped;
        if (skipped > 100000) break;
        continue;
      }
    }
    starts.push_back(s);
  }
  return starts;
}

/// Runs every start of a case (--threads in parallel), each with its own localiser seed, and
/// adds the evaluation-only figures (the map's agreement at the reference, case b's distance
/// to the leader's path).
std::vector<StartResult> run_starts(const LocaliseBenchOptions& o,
                                    const std::vector<LaserScan>& scans, const LeaderRun& leader,
                                    const BenchCase& bc, const std::vector<std::size_t>& starts) {
  std::vector<StartResult> results(starts.size());
  std::atomic<int> done{0};
  std::mutex print_mutex;
  parallel_for(o.threads, starts.size(), [&](std::size_t i) {
    LocaliserConfig c = o.config;
    c.seed = o.seed * 1000003u + i;
    results[i] = run_start(c, bc.map, scans, bc.reference, starts[i], o.budget, !o.trace.empty(),
                           o.trace_all);
    {
      const ScanPoints pts = prepare_scan(scans[starts[i]], o.config.tracking);
      FitnessOptions fo;
      fo.interpolate = true;
      results[i].reference_agreement =
          FitnessEvaluator(bc.map, pts, fo).evaluate(bc.reference(starts[i])).agreement();
    }
    if (bc.half) {
      // Evaluation only: how far the leader had been from this start when it made the map.
      const Pose2 at = leader.ref[starts[i]].pose;
      double best = 1e18;
      for (std::size_t k = 0; k < leader.half; ++k) {
        best = std::min(best, std::hypot(leader.ref[k].pose.x - at.x, leader.ref[k].pose.y - at.y));
      }
      results[i].path_distance = best;
    }
    const int d = ++done;
    if (d % 10 == 0) {
      std::lock_guard<std::mutex> lock(print_mutex);
      std::fprintf(stderr, "  case %s: %d / %zu starts\n", bc.name, d, starts.size());
    }
    if (results[i].declared && !results[i].correct) {
      std::lock_guard<std::mutex> lock(print_mutex);
      std::fprintf(stderr,
                   "  case %s: WRONG pose from start scan %zu (seed %llu): %.2f m, %.1f deg\n",
                   bc.name, starts[i], static_cast<unsigned long long>(c.seed), results[i].error_xy,
                   results[i].error_theta_deg);
    }
  });
  return results;
}

/// --trace: prints where the references fell out of the failed starts' grid searches and
/// appends the starts' traces (every start with --trace-all, else the failed ones).
void trace_case(const LocaliseBenchOptions& o, const char* name,
                const std::vector<StartResult>& results, std::string& trace_text) {
  int searches = 0, lost_coarse = 0, lost_ranking = 0, found = 0;
  for (const StartResult& r : results) {
    if (r.correct) continue;
    searches += r.searches;
    lost_coarse += r.lost_coarse;
    lost_ranking += r.lost_ranking;
    found += r.found;
  }
  std::printf(
      "case %s trace: %d grid searches in the failed starts; the reference was among the "
      "candidates in %d, ranked below them in %d, not among the coarse poses in %d\n",
      name, searches, found, lost_ranking, lost_coarse);
  for (const StartResult& r : results) {
    if (r.correct && !o.trace_all) continue;
    trace_text += std::string("case ") + name + " start " + std::to_string(r.start) +
                  (r.declared ? (r.correct ? " right" : " WRONG") : " undeclared") +
                  " reference_agreement " + std::to_string(r.reference_agreement) + "\n" + r.trace;
  }
}

/// One case: draws and runs its starts, traces, prints and stores its summary in
/// out["case_<name>"]; returns the starts' results.
std::vector<StartResult> run_case(const LocaliseBenchOptions& o,
                                  const std::vector<LaserScan>& scans, const LeaderRun& leader,
                                  const BenchCase& bc, nlohmann::json& out,
                                  std::string& trace_text) {
  std::size_t skipped = 0;
  const std::vector<std::size_t> starts = draw_starts(o, scans, leader, bc, skipped);
  std::vector<StartResult> results = run_starts(o, scans, leader, bc, starts);
  if (!o.trace.empty()) trace_case(o, bc.name, results, trace_text);
  nlohmann::json j = summarize_case(results, skipped, o.budget, o.within);
  print_case(bc.name, j);
  out[std::string("case_") + bc.name] = j;
  return results;
}

/// Case b's note on the references: how far re-alignment moved those the scoring used (start
/// and declared scans; --trace looks up more, which must not change these figures).
void report_realignment(const std::vector<StartResult>& results,
                        const HalfMapReferences& references, nlohmann::json& out) {
  std::vector<std::size_t> used;
  for (const StartResult& r : results) {
    used.push_back(r.start);
    if (r.declared) used.push_back(r.declared_scan);
  }
  std::sort(used.begin(), used.end());
  used.erase(std::unique(used.begin(), used.end()), used.end());
  const auto [realigned, realign_max] = references.realignment(used);
  out["case_b"]["references_realigned_over_0_1_m"] = realigned;
  out["case_b"]["reference_realign_max_m"] = realign_max;
  std::printf(
      "case b: %zu references re-aligned by more than 0.1 m to the half map (at most %.2f m)\n",
      realigned, realign_max);
}

/// Tracking: one follower over the whole log in the whole-log map; out["tracking"]. Returns
/// false (after printing why) when the relations file cannot be evaluated.
bool run_tracking(const LocaliseBenchOptions& o, const std::vector<LaserScan>& scans,
                  const GridMap& full_map, nlohmann::json& out) {
  Localiser loc(o.config);
  std::vector<TimedPose> track;
  std::size_t lost = 0;
  std::vector<double> cpu;
  for (const LaserScan& scan : scans) {
    const LocaliserStep step = loc.process(full_map, scan);
    if (step.lost) ++lost;
    if (step.state == LocaliserState::kTracking) {
      track.push_back({scan.stamp, step.pose});
      cpu.push_back(step.cpu_ms);
    }
  }
  const app::Summary c = app::summarize(cpu);
  nlohmann::json t = {{"tracked_scans", track.size()},
                      {"lost_events", lost},
                      {"cpu_ms_median", c.median},
                      {"cpu_ms_p95", c.p95}};
  std::printf("tracking: %zu of %zu scans tracked, %zu lost events, %.2f ms CPU per scan median",
              track.size(), scans.size(), lost, c.median);
  if (!o.relations.empty()) {
    try {
      RelationsOptions ro;
      ro.time_offset = o.time_offset;
      const RelationsResult rr = evaluate_relations(track, read_relations(o.relations), ro);
      t["relations_trans_mean_m"] = rr.trans_mean;
      t["relations_rot_mean_deg"] = rr.rot_mean_deg;
      t["relations_matched"] = rr.matched;
      t["relations_outliers"] = rr.outliers;
      std::printf(", relations error %.3f m, %.2f deg (%zu matched, %zu outliers)", rr.trans_mean,
                  rr.rot_mean_deg, rr.matched, rr.outliers);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "esfleet-bench localise: relations: %s\n", e.what());
      return false;
    }
  }
  std::printf("\n");
  out["tracking"] = t;
  return true;
}

/// Kidnap: localise and track from A, then the scans jump to B (at least 10 m away);
/// out["kidnap"].
void run_kidnaps(const LocaliseBenchOptions& o, const std::vector<LaserScan>& scans,
                 const LeaderRun& leader, nlohmann::json& out) {
  const std::vector<TimedPose>& ref = leader.ref;
  std::vector<double> notice, relocalise;
  int correct = 0, wrong = 0, missed = 0;
  const std::size_t hi = scans.size() - kDrawTail;
  Rng kidnap_pick(o.seed * 1000u + 'k');
  for (int k = 0; k < o.kidnaps; ++k) {
    LocaliserConfig c = o.config;
    c.seed = o.seed * 7919u + static_cast<std::uint64_t>(k);
    Localiser loc(c);
    std::size_t a = kidnap_pick.below(static_cast<std::uint32_t>(hi));
    bool tracking = false;
    int tracked = 0;
    for (std::size_t j = a; j < scans.size() && tracked < 20; ++j) {
      const LocaliserStep s = loc.process(leader.full_map, scans[j]);
      tracking = s.state == LocaliserState::kTracking;
      if (tracking) ++tracked;
      a = j;
    }
    if (!tracking) {
      ++missed;
      continue;
    }
    std::size_t b = 0;
    for (int tries = 0; tries < 1000; ++tries) {
      b = kidnap_pick.below(static_cast<std::uint32_t>(hi));
      if (std::hypot(ref[b].pose.x - ref[a].pose.x, ref[b].pose.y - ref[a].pose.y) > 10.0) break;
    }
    double cpu = 0.0;
    int noticed = -1;
    bool relocalised = false;
    for (std::size_t j = b; j < scans.size() && j < b + 2 * static_cast<std::size_t>(o.budget);
         ++j) {
      // The kidnapped robot's clock goes on: shift B's stamps to follow A's.
      LaserScan scan = scans[j];
      scan.stamp = scans[a].stamp + (scans[j].stamp - scans[b].stamp) + 0.1;
      scan.odometry.reset();
      const LocaliserStep s = loc.process(leader.full_map, scan);
      cpu += s.cpu_ms;
      if (s.lost && noticed < 0) noticed = static_cast<int>(j - b) + 1;
      if (s.declared) {
        relocalised = true;
        if (within(s.pose, ref[j].pose, kTolXy, kTolThetaDeg)) {
          ++correct;
          relocalise.push_back(cpu * 1e-3);
        } else {
          ++wrong;
        }
        break;
      }
    }
    if (noticed > 0) notice.push_back(noticed);
    if (!relocalised) ++missed;
  }
  const app::Summary n = app::summarize(notice), r = app::summarize(relocalise);
  out["kidnap"] = {{"trials", o.kidnaps},
                   {"relocalised_correctly", correct},
                   {"relocalised_wrong", wrong},
                   {"not_relocalised", missed},
                   {"scans_to_notice_median", n.median},
                   {"cpu_s_to_relocalise_median", r.median},
                   {"cpu_s_to_relocalise_p95", r.p95}};
  std::printf(
      "kidnap: %d trials: relocalised correctly %d, wrongly %d, not %d | noticed after %.0f "
      "scans (median) | CPU to relocalise median %.3f s, p95 %.3f s\n",
      o.kidnaps, correct, wrong, missed, n.median, r.median, r.p95);
}

/// Writes `text` to `path` atomically; false (after printing why) on failure.
bool write_output(const std::string& path, const std::string& text) {
  try {
    write_file_atomically(path, text);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "esfleet-bench localise: %s\n", e.what());
    return false;
  }
  return true;
}

}  // namespace

int run_localise_bench(LocaliseBenchOptions& o) {
  std::vector<LaserScan> scans;
  if (const int status = load_log(o, scans); status != 0) return status;
  const LeaderRun leader = map_log(o, scans);
  const Reference ref_full = [&](std::size_t i) { return leader.ref[i].pose; };
  HalfMapReferences half_refs(leader, scans, o.config.tracking);
  const Reference ref_half = [&](std::size_t i) { return half_refs(i); };

  nlohmann::json out;
  out["log"] = o.log;
  out["scans"] = scans.size();
  out["budget_scans"] = o.budget;
  out["tolerance"] = {{"xy_m", kTolXy}, {"theta_deg", kTolThetaDeg}};
  out["search"] = o.config.search.method == GlobalSearchMethod::kEs ? "es" : "grid";
  out["leader_odometry"] = leader.odometry;
  out["follower_odometry"] = o.config.tracking.use_odometry;
  std::vector<StartResult> pooled;
  std::string trace_text;
  if (o.which != "b") {
    const BenchCase a{"a", leader.full_map, 0, false, ref_full};
    const std::vector<StartResult> r = run_case(o, scans, leader, a, out, trace_text);
    pooled.insert(pooled.end(), r.begin(), r.end());
  }
  if (o.which != "a") {
    const BenchCase b{"b", leader.half_map, leader.half, true, ref_half};
    const std::vector<StartResult> r = run_case(o, scans, leader, b, out, trace_text);
    pooled.insert(pooled.end(), r.begin(), r.end());
    report_realignment(r, half_refs, out);
  }
  if (!o.trace.empty() && !write_output(o.trace, trace_text)) return 1;
  const nlohmann::json all = summarize_case(pooled, 0, o.budget, o.within);
  for (const char* k : {"success_rate", "wrong_rate", "undeclared_rate", "median_s", "p95_s",
                        "scans_median", "scans_p95", "within"}) {
    out[k] = all[k];
  }
  if (!run_tracking(o, scans, leader.full_map, out)) return 1;
  if (o.kidnaps > 0) run_kidnaps(o, scans, leader, out);
  if (!write_output(o.output, out.dump(2) + "\n")) return 1;
  if (o.json) std::printf("%s\n", out.dump().c_str());
  return 0;
}

}  // namespace esfleet::bench
