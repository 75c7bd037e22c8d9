#include "contribute_bench.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/localise_params.hpp"
#include "app/slam_params.hpp"
#include "app/summary.hpp"
#include "bench_maps.hpp"
#include "esfleet/core/clock.hpp"
#include "esfleet/core/map_png.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/core/relations.hpp"

namespace esfleet::bench {

void add_contribute_bench_options(CLI::App& cmd, ContributeBenchOptions& o) {
  cmd.add_option("--log", o.log, "CARMEN log: the leader maps its first part, followers the rest")
      ->required();
  cmd.add_option("--relations", o.relations, "relations file: the trajectories' error")->required();
  cmd.add_option("--time-offset", o.time_offset, "relation stamp = trajectory stamp + this")
      ->capture_default_str();
  cmd.add_option("--robots", o.robots, "followers (the first starts where the leader stopped)")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd.add_option("--bench-seed", o.seed, "seed of the start draw and the localisers")
      ->capture_default_str();
  cmd.add_option("--overlap", o.overlap,
                 "scans a follower drives on past the next follower's start")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd.add_option("--lead-in", o.lead_in,
                 "the first follower starts this many scans before the leader's last one, on "
                 "its path (0: at the first scan the leader did not map)")
      ->check(CLI::Range(0, 100000))
      ->capture_default_str();
  cmd.add_option("--leader-share", o.leader_share, "the share of the log the leader maps")
      ->check(CLI::Range(0.05, 0.95))
      ->capture_default_str();
  cmd.add_option("--contribute", o.contribute,
                 "followers contribute their scans (off: they only localise, the baseline)")
      ->capture_default_str();
  cmd.add_option("--contribute-min-agreement", o.contributor.min_agreement,
                 "a follower sends a tracked scan whose agreement with the map is at least this")
      ->capture_default_str();
  cmd.add_option("--claim-offset", o.claim_offset,
                 "dx,dy,dtheta_deg added to every pose a follower claims (robots whose pose is "
                 "wrong: what the leader's checks catch)")
      ->delimiter(',')
      ->expected(3)
      ->capture_default_str();
  cmd.add_option("--png", o.png, "write the final map with the combined trajectory here");
  cmd.add_option("--output", o.output, "JSON file for the figures")->capture_default_str();
  cmd.add_flag("--json", o.json, "last line of stdout is the JSON object");
  app::add_slam_params(o.params, &o.slam, &o.reader);
  app::add_localise_params(o.params, &o.localiser);
  o.params.bind(cmd, "Parameters (leader SLAM and followers)");
}

namespace {

/// Share of the cells `ref` observed that `map` observed too, within `reach` cells.
double coverage(const GridMap& ref, const GridMap& map, int reach) {
  std::size_t known = 0, covered = 0;
  const int edge = ref.tile_edge();
  for (const TileKey& k : ref.tile_keys()) {
    const Tile* t = ref.find_tile(k);
    for (int cy = 0; cy < edge; ++cy) {
      for (int cx = 0; cx < edge; ++cx) {
        const std::size_t i = static_cast<std::size_t>(cy) * edge + cx;
        if (t->hit[i] + t->err[i] == 0) continue;
        ++known;
        const CellIndex c{k.tx * edge + cx, k.ty * edge + cy};
        bool found = false;
        for (int dy = -reach; dy <= reach && !found; ++dy) {
          for (int dx = -reach; dx <= reach && !found; ++dx) {
            const CellIndex n{c.x + dx, c.y + dy};
            found = map.hit(n) + map.err(n) > 0;
          }
        }
        if (found) ++covered;
      }
    }
  }
  return known > 0 ? static_cast<double>(covered) / static_cast<double>(known) : 0.0;
}

/// One follower: its stretch of the log, its localiser and what it did.
struct Robot {
  std::string id;
  std::size_t start = 0, end = 0, next = 0;
  Localiser localiser;
  std::optional<Pose2> last_sent;
  std::uint32_t seq = 0;
  std::vector<std::optional<Pose2>> tracked;  ///< per scan of the log
  std::size_t sent = 0, accepted = 0, redundant = 0, bytes = 0;
  std::map<std::string, std::size_t> rejected;
  std::size_t scans_to_pose = 0;
  bool declared = false;
  explicit Robot(LocaliserConfig c) : localiser(std::move(c)) {}
};

nlohmann::json relations_json(const RelationsResult& r) {
  return {{"trans_mean_m", r.trans_mean},
          {"rot_mean_deg", r.rot_mean_deg},
          {"matched", r.matched},
          {"outliers", r.outliers},
          {"trans_max_m", r.trans_max}};
}

/// Case (b) starts: the first at `half`, the others drawn from the second half where the
/// half map knows at least half of the scan's end points at the whole-log pose.
std::vector<std::size_t> draw_starts(const ContributeBenchOptions& o,
                                     const std::vector<LaserScan>& scans, std::size_t half,
                                     const GridMap& half_map,
                                     const std::vector<TimedPose>& reference) {
  std::vector<std::size_t> starts{half - std::min(half, static_cast<std::size_t>(o.lead_in))};
  Rng rng(o.seed);
  const std::size_t lo = half + 100, hi = scans.size() > 400 ? scans.size() - 300 : lo + 1;
  for (int attempt = 0; attempt < 5000 && starts.size() < static_cast<std::size_t>(o.robots);
       ++attempt) {
    const std::size_t s = lo + rng.below(static_cast<std::uint32_t>(hi - lo));
    bool apart = true;
    for (const std::size_t t : starts) apart = apart && (s > t ? s - t : t - s) >= 150;
    if (!apart) continue;
    const ScanPoints pts = prepare_scan(scans[s]);
    const FitnessValue v =
        FitnessEvaluator(half_map, pts, FitnessOptions{}).evaluate(reference[s].pose);
    if (v.known_share() >= 0.5) starts.push_back(s);
  }
  std::sort(starts.begin(), starts.end());
  return starts;
}

}  // namespace

int run_contribute_bench(ContributeBenchOptions& o) {
  std::vector<LaserScan> scans;
  std::vector<Relation> relations;
  try {
    o.params.apply();
    o.localiser.tracking = o.slam.tracking;
    o.slam.validate();
    o.localiser.validate();
    o.contributor.validate();
    scans = read_carmen_log(o.log, o.reader);
    relations = read_relations(o.relations);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "esfleet-bench contribute: %s\n", e.what());
    return 2;
  }
  const std::size_t n = scans.size();
  const auto half = static_cast<std::size_t>(o.leader_share * static_cast<double>(n));
  if (n < 1000) {
    std::fprintf(stderr, "esfleet-bench contribute: %s has %zu scans, too few (1000)\n",
                 o.log.c_str(), n);
    return 2;
  }
  RelationsOptions ro;
  ro.time_offset = o.time_offset;

  // Evaluation only: the leader's map of the whole log and its poses.
  std::fprintf(stderr, "%s: %zu scans; the whole-log leader (reference) ...\n", o.log.c_str(), n);
  Slam full(o.slam);
  for (const LaserScan& s : scans) full.process(s);
  full.finish();

  std::fprintf(stderr, "the leader maps scans 0 .. %zu ...\n", half - 1);
  Slam lead(o.slam);
  for (std::size_t i = 0; i < half; ++i) lead.process(scans[i]);
  lead.finish();
  const double leader_coverage = coverage(full.map(), lead.map(), 2);
  const std::size_t leader_tiles = lead.map().tile_count();

  const std::vector<std::size_t> starts =
      draw_starts(o, scans, half, lead.map(), full.trajectory());
  // The followers' copy of the map, kept up to date with the leader's changed tiles.
  GridMap replica = copy_map(lead.map(), o.localiser.search.coarse_level);
  lead.map().take_dirty();
  std::vector<Robot> robots;
  for (std::size_t i = 0; i < starts.size(); ++i) {
    LocaliserConfig c = o.localiser;
    c.seed = o.seed * 1000 + i + 1;
    Robot r(c);
    r.id = "robot" + std::to_string(i + 1);
    r.start = r.next = starts[i];
    r.end = i + 1 < starts.size() ? std::min(n, starts[i + 1] + o.overlap) : n;
    r.tracked.resize(n);
    robots.push_back(std::move(r));
    std::fprintf(stderr, "  %s: scans %zu .. %zu\n", robots.back().id.c_str(), r.start, r.end - 1);
  }

  std::vector<double> cpu_ms;
  std::size_t loops = 0;
  for (;;) {
    // The robot whose next scan comes first in time since its own start.
    Robot* due = nullptr;
    double due_t = 0.0;
    for (Robot& r : robots) {
      if (r.next >= r.end) continue;
      const double t = scans[r.next].stamp - scans[r.start].stamp;
      if (due == nullptr || t < due_t) {
        due = &r;
        due_t = t;
      }
    }
    if (due == nullptr) break;
    Robot& r = *due;
    const std::size_t j = r.next++;
    const LocaliserStep step = r.localiser.process(replica, scans[j]);
    if (step.declared && !r.declared) {
      r.declared = true;
      r.scans_to_pose = j - r.start + 1;
    }
    if (step.state != LocaliserState::kTracking || step.declared) continue;
    r.tracked[j] = step.pose;
    if (!o.contribute || !worth_contributing(o.contributor, step.value, step.pose, r.last_sent)) {
      continue;
    }
    Contribution c;
    c.robot = r.id;
    c.seq = r.seq++;
    c.scan = scans[j];
    c.pose = {step.pose.x + o.claim_offset[0], step.pose.y + o.claim_offset[1],
              normalize_angle(step.pose.theta + deg_to_rad(o.claim_offset[2]))};
    r.last_sent = step.pose;
    ++r.sent;
    r.bytes += 2 * c.scan.ranges.size() + 128;  // ranges in mm + header, as on the wire
    const double t0 = thread_cpu_seconds();
    const ContributionResult res = lead.contribute(c);
    cpu_ms.push_back((thread_cpu_seconds() - t0) * 1e3);
    if (res.accepted()) {
      ++r.accepted;
    } else if (!res.rejected()) {
      ++r.redundant;
    } else {
      ++r.rejected[to_string(res.verdict)];
    }
    loops += res.loop_closed ? 1 : 0;
    for (const TileKey& k : lead.map().take_dirty()) {
      const Tile* t = lead.map().find_tile(k);
      replica.set_tile(k, t->version, t->hit, t->err);
    }
  }

  // Scoring (evaluation only).
  nlohmann::json robots_json = nlohmann::json::array();
  std::vector<std::optional<Pose2>> merged(n);
  for (std::size_t i = 0; i < robots.size(); ++i) {
    const Robot& r = robots[i];
    std::vector<TimedPose> traj;
    for (std::size_t j = r.start; j < r.end; ++j) {
      if (!r.tracked[j]) continue;
      traj.push_back({scans[j].stamp, *r.tracked[j]});
      // Where robots overlap, the one that started later (it drives on from there).
      merged[j] = r.tracked[j];
    }
    const RelationsResult rel = evaluate_relations(traj, relations, ro);
    std::size_t rejected = 0;
    for (const auto& [why, k] : r.rejected) rejected += k;
    const double seconds = scans[r.end - 1].stamp - scans[r.start].stamp;
    robots_json.push_back(
        {{"robot", r.id},
         {"start", r.start},
         {"end", r.end},
         {"scans_to_pose", r.declared ? static_cast<long>(r.scans_to_pose) : -1},
         {"tracked", traj.size()},
         {"sent", r.sent},
         {"accepted", r.accepted},
         {"redundant", r.redundant},
         {"rejected", rejected},
         {"rejected_by", r.rejected},
         {"uplink_bytes_per_s", seconds > 0 ? static_cast<double>(r.bytes) / seconds : 0.0},
         {"relations", relations_json(rel)}});
  }
  std::vector<TimedPose> followers, combined;
  for (std::size_t j = 0; j < n; ++j) {
    if (j < half) {
      combined.push_back(lead.trajectory()[j]);
    } else if (merged[j]) {
      followers.push_back({scans[j].stamp, *merged[j]});
      combined.push_back(followers.back());
    }
  }
  const RelationsResult fol = evaluate_relations(followers, relations, ro);
  const RelationsResult comb = evaluate_relations(combined, relations, ro);
  const RelationsResult whole = evaluate_relations(full.trajectory(), relations, ro);
  const app::Summary cpu = app::summarize(cpu_ms);
  const nlohmann::json out = {{"log", o.log},
                              {"scans", n},
                              {"leader_scans", half},
                              {"robots", robots.size()},
                              {"contribute", o.contribute},
                              {"seed", o.seed},
                              {"claim_offset", o.claim_offset},
                              {"coverage", coverage(full.map(), lead.map(), 2)},
                              {"coverage_strict", coverage(full.map(), lead.map(), 0)},
                              {"coverage_leader_alone", leader_coverage},
                              {"tiles", lead.map().tile_count()},
                              {"tiles_leader_alone", leader_tiles},
                              {"tiles_whole_log", full.map().tile_count()},
                              {"contributed_keys", lead.contributed_keys()},
                              {"loops_closed_by_contributions", loops},
                              {"leader_cpu_ms_per_contribution",
                               {{"median", cpu.median}, {"p95", cpu.p95}, {"max", cpu.max}}},
                              {"followers_relations", relations_json(fol)},
                              {"combined_relations", relations_json(comb)},
                              {"whole_log_leader_relations", relations_json(whole)},
                              {"per_robot", robots_json}};
  std::printf("%s, leader scans 0-%zu, %zu followers, contribute %s, seed %llu\n", o.log.c_str(),
              half - 1, robots.size(), o.contribute ? "on" : "off",
              static_cast<unsigned long long>(o.seed));
  std::printf("  coverage of the whole-log map: %.1f %% (leader alone %.1f %%, strict %.1f %%)\n",
              100 * out["coverage"].get<double>(), 100 * leader_coverage,
              100 * out["coverage_strict"].get<double>());
  for (const nlohmann::json& r : robots_json) {
    std::printf(
        "  %s scans %d-%d: pose after %d scans, %d tracked, %d sent, %d accepted, "
        "%d redundant, %d rejected, %.0f B/s, relations %.3f m (%d)\n",
        r["robot"].get<std::string>().c_str(), r["start"].get<int>(), r["end"].get<int>() - 1,
        r["scans_to_pose"].get<int>(), r["tracked"].get<int>(), r["sent"].get<int>(),
        r["accepted"].get<int>(), r["redundant"].get<int>(), r["rejected"].get<int>(),
        r["uplink_bytes_per_s"].get<double>(), r["relations"]["trans_mean_m"].get<double>(),
        r["relations"]["matched"].get<int>());
  }
  std::printf(
      "  followers' trajectory %.3f m (%zu relations), combined %.3f m (%zu), whole-log "
      "leader %.3f m (%zu)\n",
      fol.trans_mean, fol.matched, comb.trans_mean, comb.matched, whole.trans_mean, whole.matched);
  std::printf("  leader CPU per contribution: median %.2f ms, p95 %.2f ms\n", cpu.median, cpu.p95);
  if (!o.png.empty()) save_map_png(lead.map(), combined, o.png);
  std::ofstream f(o.output);
  f << out.dump(2) << "\n";
  if (o.json) std::printf("%s\n", out.dump().c_str());
  return f ? 0 : 1;
}

}  // namespace esfleet::bench
