#include "generalise.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <utility>

#include "app/program.hpp"
#include "app/slam_params.hpp"
#include "app/summary.hpp"
#include "esfleet/core/file_io.hpp"
#include "esfleet/sim/fleet.hpp"
#include "esfleet/sim/world.hpp"
#include "generalise_data.hpp"
#include "parallel_for.hpp"

namespace esfleet::bench {

namespace {

/// Derived-relation gaps, in kept scans with a reference pose.
const std::vector<std::size_t> kGaps = {1, 5, 20, 100};
const std::vector<std::size_t> kCsailKs = {1, 2, 3, 4, 5};
const std::vector<std::size_t> kFr079Ks = {1, 2, 4, 6, 8};
constexpr double kFr079TimeOffset = 1211.45;  // fr079 relation stamp = log stamp + this

struct RunSpec {
  std::size_t log = 0;  ///< index into the loaded logs
  std::size_t k = 1;
  GeneraliseMode mode = GeneraliseMode::kLaserOnly;
  std::uint64_t seed = 1;
};

struct RunResult {
  std::size_t scans = 0;
  std::size_t key_scans = 0;
  std::size_t loop_closures = 0;
  KeptRelations relations;
  KeptDerived derived;
  /// The derived score of a run on every scan of the same log (csail for csail-keys), same mode
  /// and seed, at this run's kept scans (score_derived_floor); unset when there is none.
  std::optional<KeptDerived> floor;
  std::vector<Pose2> estimate;  ///< one pose per kept scan (kept for the floors of other runs)
  app::Summary scan_ms;
  double run_s = 0.0;
  std::string error;  ///< set when the run threw
};

GeneraliseMode parse_mode(const std::string& m) {
  return m == "laser" ? GeneraliseMode::kLaserOnly : GeneraliseMode::kNoisyOdometry;
}

/// Reads a log and its relations; a failure is a UsageError naming the file.
std::vector<LaserScan> read_log(const std::string& path, const CarmenReaderOptions& reader) {
  std::vector<LaserScan> scans;
  app::setup_step("", [&] { scans = read_carmen_log(path, reader); });
  return scans;
}

std::vector<Relation> read_rel(const std::string& path) {
  std::vector<Relation> relations;
  app::setup_step("", [&] { relations = read_relations(path); });
  return relations;
}

/// A simulated world of --logs: its map (data/worlds/<dir>/map.yaml), the clearance its robot
/// keeps and its logs' name prefix.
struct SimWorld {
  const char* log;  ///< the --logs value
  const char* dir;  ///< under <data-dir>/worlds/
  double clearance;
  const char* prefix;  ///< its logs are <prefix><simulation seed>
};
/// fr079's map narrows to about 0.6 m where its corridor meets the hall (the recording robot
/// passed; 0.35 m of clearance leaves the robot 25 m^2 of the corridor's west half, 0.25 m the
/// whole corridor and several rooms).
constexpr std::array<SimWorld, 2> kSimWorlds = {
    {{"sim", "mit-csail", 0.35, "sim-"}, {"sim-fr079", "fr079", 0.25, "sim-fr079-"}}};

/// The simulation of the robot of --logs world `w` with the options' rate, motion and laser (by
/// default one scan per second at up to 1 m/s, 181 beams over 180 degrees, 30 m range). Throws
/// std::invalid_argument naming the bench's flag (--sim-speed) for a value out of range.
sim::FleetConfig simulated_robot(const GeneraliseOptions& o, const SimWorld& w) {
  sim::FleetConfig fc;
  fc.rate = o.sim_rate;
  fc.motion = o.sim_motion;
  fc.motion.clearance = o.sim_clearance >= 0.0 ? o.sim_clearance : w.clearance;
  fc.laser = o.sim_laser;
  fc.start_stamp = 1000.0;
  try {
    fc.validate();
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    throw std::invalid_argument(what.rfind("--", 0) == 0 ? "--sim-" + what.substr(2) : what);
  }
  return fc;
}

/// A simulated log (evaluation data only: the SLAM gets its scans through slam_input): the
/// robot `fc` of simulation seed `seed` in `world` for `duration_s`. Every scan's reference pose
/// is the truth, and so is its odometry field (the source of the noisy odometry, as the
/// corrected poses are for fr079). No hand-made relations.
GeneraliseLog make_simulated_log(const sim::World& world, const SimWorld& w, sim::FleetConfig fc,
                                 std::uint64_t seed, double duration_s,
                                 const std::string& world_path) {
  fc.seed = seed;
  sim::Fleet fleet(world, fc);
  GeneraliseLog log;
  log.name = w.prefix + std::to_string(seed);
  log.path = world_path;
  const auto ticks = static_cast<std::size_t>(std::floor(duration_s * fc.rate));
  for (std::size_t i = 0; i < ticks; ++i) {
    const sim::RobotSample& s = fleet.tick().front();
    LaserScan scan = s.scan;
    scan.odometry = s.truth.pose;
    log.scans.push_back(std::move(scan));
    log.reference.emplace_back(s.truth.pose);
    log.match_index.push_back(i);
  }
  return log;
}

bool is_simulated(const GeneraliseLog& log) { return log.name.rfind("sim-", 0) == 0; }

/// The logs asked for, in the order of --logs.
std::vector<GeneraliseLog> load_logs(const GeneraliseOptions& o,
                                     const std::vector<std::uint64_t>& sim_seeds) {
  const std::string csail_raw = o.data_dir + "/mit-csail/mit-csail.clf.gz";
  const std::string csail_keys = o.data_dir + "/mit-csail/csail-corrected.log.gz";
  const std::string csail_rel = o.data_dir + "/mit-csail/mit-csail.relations";
  const std::string fr079 = o.data_dir + "/fr079/fr079-corrected.log.gz";
  const std::string fr079_rel = o.data_dir + "/fr079/fr079.relations";

  std::vector<LaserScan> raw, keys;
  std::vector<std::size_t> key_index;
  const bool need_csail = std::any_of(o.logs.begin(), o.logs.end(), [](const std::string& l) {
    return l == "csail" || l == "csail-keys";
  });
  if (need_csail) {
    raw = read_log(csail_raw, o.reader);
    keys = read_log(csail_keys, o.reader);
    app::setup_step("", [&] { key_index = match_key_scans(keys, raw, csail_keys, csail_raw); });
  }
  std::vector<GeneraliseLog> logs;
  for (const std::string& name : o.logs) {
    app::setup_step(name, [&] {
      if (name == "csail-keys") {
        logs.push_back(make_key_scan_log(keys, raw, read_rel(csail_rel), csail_keys, csail_raw));
      } else if (name == "csail") {
        std::vector<Pose2> key_poses;
        for (const LaserScan& s : keys) key_poses.push_back(s.odometry.value_or(Pose2{}));
        logs.push_back(
            make_raw_log_with_keys(raw, key_index, key_poses, read_rel(csail_rel), csail_raw));
      } else if (const auto w = std::find_if(kSimWorlds.begin(), kSimWorlds.end(),
                                             [&](const SimWorld& x) { return name == x.log; });
                 w != kSimWorlds.end()) {
        const std::string world_path = o.data_dir + "/worlds/" + w->dir + "/map.yaml";
        const sim::World world = sim::load_world(world_path);
        for (const std::uint64_t seed : sim_seeds) {
          logs.push_back(make_simulated_log(world, *w, simulated_robot(o, *w), seed,
                                            o.sim_duration_s, world_path));
        }
      } else {
        std::vector<LaserScan> scans = read_log(fr079, o.reader);
        logs.push_back(make_corrected_log(std::move(scans), read_rel(fr079_rel), kFr079TimeOffset,
                                          "fr079", fr079));
      }
    });
  }
  return logs;
}

RunResult run_one(const GeneraliseLog& log, const RunSpec& spec, const GeneraliseOptions& o) {
  RunResult r;
  const std::vector<std::size_t> kept = subsample_indices(log.scans.size(), spec.k, o.max_scans);
  std::vector<LaserScan> scans = slam_input(log, kept, spec.mode, o.noise, spec.seed);
  for (LaserScan& scan : scans) scan = keep_every_beam(std::move(scan), o.beam_step);
  SlamConfig config = o.config;
  config.seed = spec.seed;
  config.tracking.use_odometry = spec.mode == GeneraliseMode::kNoisyOdometry;
  Slam slam(config);
  std::vector<double> scan_ms;
  scan_ms.reserve(scans.size());
  const auto start = std::chrono::steady_clock::now();
  for (const LaserScan& scan : scans) {
    const auto t0 = std::chrono::steady_clock::now();
    slam.process(scan);
    scan_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  slam.finish();  // as esfleet-leader does when its input ends
  r.run_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.scan_ms = app::summarize(std::move(scan_ms));
  r.scans = scans.size();
  r.key_scans = slam.key_scans();
  r.loop_closures = slam.loop_closures();
  std::vector<Pose2> estimate;
  for (const TimedPose& p : slam.trajectory()) estimate.push_back(p.pose);
  r.relations = score_kept_relations(log, kept, estimate);
  r.derived = score_kept_derived(log, kept, estimate, kGaps);
  r.estimate = std::move(estimate);
  return r;
}

/// The run's poses beside the reference's (evaluation output), one line per kept scan.
void write_trajectory(const std::string& dir, const GeneraliseLog& log, const RunSpec& s,
                      std::size_t max_scans, const std::vector<Pose2>& estimate) {
  std::filesystem::create_directories(dir);
  const std::vector<std::size_t> kept = subsample_indices(log.scans.size(), s.k, max_scans);
  std::string text = "# kept scan, scan of " + log.name + ", x y theta, reference x y theta\n";
  char line[256];
  for (std::size_t j = 0; j < kept.size() && j < estimate.size(); ++j) {
    const std::optional<Pose2>& ref = log.reference[kept[j]];
    const double nan = std::numeric_limits<double>::quiet_NaN();
    std::snprintf(line, sizeof line, "%zu %zu %.6f %.6f %.6f %.6f %.6f %.6f\n", j, kept[j],
                  estimate[j].x, estimate[j].y, estimate[j].theta, ref ? ref->x : nan,
                  ref ? ref->y : nan, ref ? ref->theta : nan);
    text += line;
  }
  write_file_atomically(dir + "/" + log.name + "-k" + std::to_string(s.k) + "-" +
                            mode_name(s.mode) + "-s" + std::to_string(s.seed) + ".txt",
                        text);
}

/// Each run that kept part of a log gets the floor of its derived score from the run on every
/// scan of that log (the raw CSAIL log for the key-scan log), same mode and seed, when that run
/// is in the set and did not fail.
void attach_floors(const std::vector<GeneraliseLog>& logs, const std::vector<RunSpec>& specs,
                   std::size_t max_scans, std::vector<RunResult>& results) {
  const auto dense_log_of = [&](std::size_t l) -> std::optional<std::size_t> {
    if (is_simulated(logs[l])) return std::nullopt;
    const std::string dense = logs[l].name == "csail-keys" ? "csail" : logs[l].name;
    const auto it = std::find_if(logs.begin(), logs.end(),
                                 [&](const GeneraliseLog& x) { return x.name == dense; });
    if (it == logs.end()) return std::nullopt;
    return static_cast<std::size_t>(it - logs.begin());
  };
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const RunSpec& s = specs[i];
    const std::optional<std::size_t> d = dense_log_of(s.log);
    if (!results[i].error.empty() || !d || (*d == s.log && s.k == 1)) continue;
    const auto whole = std::find_if(specs.begin(), specs.end(), [&](const RunSpec& t) {
      return t.log == *d && t.k == 1 && t.mode == s.mode && t.seed == s.seed;
    });
    if (whole == specs.end()) continue;
    const RunResult& w = results[static_cast<std::size_t>(whole - specs.begin())];
    if (!w.error.empty()) continue;
    const std::vector<std::size_t> kept =
        subsample_indices(logs[s.log].scans.size(), s.k, max_scans);
    results[i].floor = score_derived_floor(logs[s.log], kept, w.estimate, kGaps);
  }
}

/// A statistic that is undefined without samples is null in the JSON, not 0.
nlohmann::json stat(std::size_t n, double v) { return n > 0 ? nlohmann::json(v) : nullptr; }

/// One object per gap: its relations' count and mean errors.
nlohmann::json gaps_json(const DerivedRelationsResult& d) {
  nlohmann::json gaps = nlohmann::json::array();
  for (const DerivedGap& g : d.gaps) {
    gaps.push_back({{"gap", g.gap},
                    {"count", g.count},
                    {"trans_mean", stat(g.count, g.trans_mean)},
                    {"rot_mean_deg", stat(g.count, g.rot_mean_deg)}});
  }
  return gaps;
}

nlohmann::json run_json(const GeneraliseLog& log, const RunSpec& s, const RunResult& r) {
  const RelationsResult& rel = r.relations.result;
  const DerivedRelationsResult& d = r.derived.result;
  return {
      {"log", log.name},
      {"k", s.k},
      {"mode", mode_name(s.mode)},
      {"seed", s.seed},
      {"scans", r.scans},
      {"key_scans", r.key_scans},
      {"loop_closures", r.loop_closures},
      {"relations",
       {{"used", r.relations.used},
        {"total", r.relations.total},
        {"trans_mean", stat(rel.matched, rel.trans_mean)},
        {"trans_std", stat(rel.matched, rel.trans_std)},
        {"rot_mean_deg", stat(rel.matched, rel.rot_mean_deg)},
        {"trans_max", stat(rel.matched, rel.trans_max)},
        {"outliers", rel.outliers}}},
      {"derived",
       {{"reference_scans", r.derived.reference_scans},
        {"count", d.count},
        {"trans_mean", stat(d.count, d.trans_mean)},
        {"trans_std", stat(d.count, d.trans_std)},
        {"rot_mean_deg", stat(d.count, d.rot_mean_deg)},
        {"trans_max", stat(d.count, d.trans_max)},
        {"gaps", gaps_json(d)}}},
      {"derived_floor",
       r.floor
           ? nlohmann::json{{"count", r.floor->result.count},
                            {"trans_mean", stat(r.floor->result.count, r.floor->result.trans_mean)},
                            {"rot_mean_deg",
                             stat(r.floor->result.count, r.floor->result.rot_mean_deg)},
                            {"gaps", gaps_json(r.floor->result)}}
           : nlohmann::json(nullptr)},
      {"timing",
       {{"scan_ms_median", r.scan_ms.median}, {"scan_ms_p95", r.scan_ms.p95}, {"run_s", r.run_s}}}};
}

struct Range {
  double min = 0, median = 0, max = 0;
  std::size_t n = 0;
};

Range range_of(std::vector<double> v) {
  Range r;
  r.n = v.size();
  if (v.empty()) return r;
  std::sort(v.begin(), v.end());
  r.min = v.front();
  r.max = v.back();
  r.median = app::summarize(v).median;
  return r;
}

nlohmann::json range_json(const Range& r) {
  if (r.n == 0) return nullptr;
  return {{"min", r.min}, {"median", r.median}, {"max", r.max}};
}

/// "a–b" over seeds ("a" for one seed), or "n/a".
std::string cell(const Range& r) {
  if (r.n == 0) return "n/a";
  char buf[64];
  if (r.n == 1 || r.min == r.max) {
    std::snprintf(buf, sizeof buf, "%.3f", r.min);
  } else {
    std::snprintf(buf, sizeof buf, "%.3f–%.3f", r.min, r.max);
  }
  return buf;
}

}  // namespace

void add_generalise_options(CLI::App& cmd, GeneraliseOptions& o) {
  cmd.add_option("--data-dir", o.data_dir,
                 "the directory holding mit-csail/ (mit-csail.clf.gz, csail-corrected.log.gz, "
                 "mit-csail.relations), fr079/ (fr079-corrected.log.gz, fr079.relations) and "
                 "worlds/mit-csail/map.yaml and worlds/fr079/map.yaml (--logs sim, sim-fr079)")
      ->capture_default_str();
  cmd.add_option("--logs", o.logs,
                 "logs to run: csail-keys (the 406 key scans of csail-corrected.log.gz), csail "
                 "(mit-csail.clf.gz), fr079, sim and sim-fr079 (simulated in the CSAIL and "
                 "the Freiburg 079 world, one log per --sim-seeds; comma-separated)")
      ->delimiter(',')
      ->check(CLI::IsMember({"csail-keys", "csail", "fr079", "sim", "sim-fr079"}))
      ->capture_default_str();
  cmd.add_option("--sim-seeds", o.sim_seeds,
                 "--logs sim, sim-fr079: one log per simulation seed (1-4, 1,2,3 or a mix): a "
                 "robot driving to random goals in data/worlds/mit-csail (0.35 m from walls) or "
                 "data/worlds/fr079 (0.25 m) at up to 1 m/s, one 181-beam 1 deg scan per second "
                 "(a key-scan log), scored against its true poses")
      ->capture_default_str();
  cmd.add_option("--sim-duration", o.sim_duration_s,
                 "--logs sim, sim-fr079: seconds of each simulated log (--sim-rate scans each)")
      ->check(CLI::Range(2.0, 36000.0))
      ->capture_default_str();
  cmd.add_option("--sim-rate", o.sim_rate,
                 "--logs sim, sim-fr079: scans per second (1: a key-scan log, the robot moving up "
                 "to --sim-speed metres between scans; 5 or more: a dense log)")
      ->capture_default_str();
  cmd.add_option("--sim-speed", o.sim_motion.speed,
                 "--logs sim, sim-fr079: the robot's top speed, m/s (at one scan a second, the "
                 "most it moves between scans)")
      ->capture_default_str();
  cmd.add_option("--sim-turn-rate", o.sim_motion.turn_rate_deg,
                 "--logs sim, sim-fr079: the robot's top turn rate, deg/s")
      ->capture_default_str();
  cmd.add_option("--sim-clearance", o.sim_clearance,
                 "--logs sim, sim-fr079: least distance of the robot to walls, m (default: the "
                 "world's, 0.35 in mit-csail, 0.25 in fr079)")
      ->check(CLI::Range(0.0, 10.0));
  cmd.add_option("--sim-beams", o.sim_laser.beams,
                 "--logs sim, sim-fr079: the laser's beams per scan")
      ->capture_default_str();
  cmd.add_option("--sim-fov", o.sim_laser.fov_deg,
                 "--logs sim, sim-fr079: the laser's field of view, deg, centred forward (360: "
                 "all round, as many 2D lidars on small robots)")
      ->capture_default_str();
  cmd.add_option("--sim-max-range", o.sim_laser.max_range,
                 "--logs sim, sim-fr079: the laser's range, m (no-return readings report it)")
      ->capture_default_str();
  cmd.add_option("--sim-range-noise", o.sim_laser.range_noise,
                 "--logs sim, sim-fr079: sigma of the laser's range noise, m")
      ->capture_default_str();
  cmd.add_option("--sim-dropout", o.sim_laser.dropout,
                 "--logs sim, sim-fr079: probability per beam of a no-return")
      ->capture_default_str();
  cmd.add_option("--ks", o.ks,
                 "keep every k-th scan of csail and fr079, for each k given (comma-separated; "
                 "default csail 1,2,3,4,5 and fr079 1,2,4,6,8); csail-keys and the simulated logs "
                 "always run whole")
      ->delimiter(',')
      ->check(CLI::Range(1, 1000));
  cmd.add_option("--modes", o.modes,
                 "laser (laser only, odometry cleared) and/or odom (noisy odometry made from the "
                 "kept scans' pose fields: corrected poses, CSAIL's raw odometry; seeded with "
                 "the run's seed)")
      ->delimiter(',')
      ->check(CLI::IsMember({"laser", "odom"}))
      ->capture_default_str();
  cmd.add_option("--seeds", o.seeds, "seeds of the runs: 1-5, 1,2,3 or a mix (1-3,7)")
      ->capture_default_str();
  cmd.add_option("--max-scans", o.max_scans,
                 "give each run at most N scans, counted after subsampling (0 = all)")
      ->capture_default_str();
  cmd.add_option("--beam-step", o.beam_step,
                 "keep every N-th beam of each scan: 2 makes the logs' 0.5 deg lasers 1 deg "
                 "ones, as many logs have (1 = every beam)")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  cmd.add_option("--jobs", o.jobs, "runs in parallel threads (scores do not depend on it)")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  cmd.add_option("--out", o.output, "JSON file for the runs and the summary")
      ->capture_default_str();
  cmd.add_option("--trajectories", o.trajectories,
                 "also write each run's poses beside the reference's to DIR/LOG-kK-MODE-sSEED.txt "
                 "(kept scan, scan of the log, x y theta, then the reference's x y theta or nan; "
                 "metres and radians), to trace where a run goes wrong");
  cmd.add_option("--distance-frac", o.noise.distance_frac,
                 "noisy odometry: translation sigma per metre driven, per step")
      ->capture_default_str();
  cmd.add_option("--turn-frac", o.noise.turn_frac,
                 "noisy odometry: heading sigma per radian turned, per step")
      ->capture_default_str();
  cmd.add_flag("--paper", o.paper,
               "start from the paper's exact configuration before applying --config and the "
               "SLAM flags below (--odometry and --seed are set per run by --modes and --seeds)");
  app::add_slam_params(o.params, &o.config, &o.reader);
  o.params.bind(cmd, "SLAM parameters");
}

int run_generalise(GeneraliseOptions& o) {
  if (o.paper) o.config = SlamConfig::paper();
  o.params.apply();
  for (const auto& [name, value] : o.params.changed()) {
    if (name == "odometry" || name == "seed") {
      throw app::UsageError("--" + std::string(name == "seed" ? "seed" : "odometry") +
                            " is set per run here: use --" + (name == "seed" ? "seeds" : "modes"));
    }
  }
  try {
    o.config.validate();
    o.noise.validate();
  } catch (const std::invalid_argument& e) {
    throw app::UsageError(e.what());
  }
  std::vector<std::uint64_t> seeds;
  try {
    seeds = parse_seed_list(o.seeds);
  } catch (const std::invalid_argument& e) {
    throw app::UsageError(std::string("--") + e.what());
  }

  std::vector<std::uint64_t> sim_seeds;
  try {
    sim_seeds = parse_seed_list(o.sim_seeds);
  } catch (const std::invalid_argument& e) {
    throw app::UsageError(std::string("--sim-seeds: ") + e.what());
  }
  try {
    simulated_robot(o, kSimWorlds.front());  // the --sim-* flags, before any log is read
  } catch (const std::invalid_argument& e) {
    throw app::UsageError(e.what());
  }
  const std::vector<GeneraliseLog> logs = load_logs(o, sim_seeds);
  std::vector<RunSpec> specs;
  for (std::size_t l = 0; l < logs.size(); ++l) {
    std::vector<std::size_t> ks = {1};
    if (logs[l].name != "csail-keys" && !is_simulated(logs[l])) {
      ks = !o.ks.empty() ? o.ks : logs[l].name == "fr079" ? kFr079Ks : kCsailKs;
    }
    for (std::size_t k : ks) {
      for (const std::string& m : o.modes) {
        for (std::uint64_t seed : seeds) specs.push_back({l, k, parse_mode(m), seed});
      }
    }
  }
  nlohmann::json log_info = nlohmann::json::array();
  for (const GeneraliseLog& log : logs) {
    std::size_t references = 0, matched = 0;
    for (const auto& p : log.reference) references += p ? 1 : 0;
    for (const auto& e : log.relation_ends) matched += e ? 1 : 0;
    std::fprintf(stderr, "%s: %zu scans, %zu with a reference pose, %zu of %zu relations matched",
                 log.name.c_str(), log.scans.size(), references, matched, log.relations.size());
    nlohmann::json info = {{"log", log.name},
                           {"path", log.path},
                           {"scans", log.scans.size()},
                           {"reference_scans", references},
                           {"relations", log.relations.size()},
                           {"relations_matched", matched},
                           {"relations_time_offset", log.relation_options.time_offset}};
    if (log.name == "csail-keys" && log.match_index.size() > 1) {
      // How far apart the key scans are in the raw log (the recovered raw indices).
      std::vector<double> gaps;
      for (std::size_t i = 1; i < log.match_index.size(); ++i) {
        gaps.push_back(static_cast<double>(log.match_index[i] - log.match_index[i - 1]));
      }
      const auto [lo, hi] = std::minmax_element(gaps.begin(), gaps.end());
      const double median = app::summarize(gaps).median;
      info["raw_index_gap"] = {{"min", *lo}, {"median", median}, {"max", *hi}};
      std::fprintf(stderr, "; raw scans %zu..%zu, %g apart (median, %g..%g)",
                   log.match_index.front(), log.match_index.back(), median, *lo, *hi);
    }
    // How far the robot moved between consecutive scans with a reference, and how far the
    // laser saw: what a run had to hold through.
    std::vector<double> step_m, step_deg;
    for (std::size_t i = 1; i < log.reference.size(); ++i) {
      if (!log.reference[i] || !log.reference[i - 1]) continue;
      const Pose2 d = log.reference[i]->relative_to(*log.reference[i - 1]);
      step_m.push_back(std::hypot(d.x, d.y));
      step_deg.push_back(std::abs(rad_to_deg(d.theta)));
    }
    if (!step_m.empty()) {
      const double max_m = *std::max_element(step_m.begin(), step_m.end());
      const double max_deg = *std::max_element(step_deg.begin(), step_deg.end());
      info["reference_step"] = {{"median_m", app::summarize(step_m).median},
                                {"max_m", max_m},
                                {"median_deg", app::summarize(step_deg).median},
                                {"max_deg", max_deg}};
      std::fprintf(stderr, "; steps up to %.2f m and %.0f deg", max_m, max_deg);
    }
    float farthest = 0.0f;
    for (const LaserScan& scan : log.scans) {
      for (std::size_t b = 0; b < scan.ranges.size(); ++b) {
        if (!scan.is_no_return(b)) farthest = std::max(farthest, scan.ranges[b]);
      }
    }
    info["farthest_return_m"] = farthest;
    if (!log.scans.empty()) {
      // The laser as logged (before --beam-step): a 180 deg laser's first and last beams are
      // 180 deg apart, an all-round one's 360 deg less one increment.
      const LaserScan& first = log.scans.front();
      const auto beams = first.ranges.size();
      const double first_to_last = rad_to_deg(static_cast<double>(first.angle_increment) *
                                              static_cast<double>(beams > 0 ? beams - 1 : 0));
      info["laser"] = {{"beams", beams},
                       {"angle_min_deg", rad_to_deg(first.angle_min)},
                       {"angle_increment_deg", rad_to_deg(first.angle_increment)},
                       {"first_to_last_deg", first_to_last}};
      std::fprintf(stderr, "; %zu beams, %.4g deg from first to last", beams, first_to_last);
    }
    std::fprintf(stderr, "\n");
    log_info.push_back(info);
  }
  std::fprintf(stderr, "%zu runs, %d job(s)\n", specs.size(), o.jobs);

  std::vector<RunResult> results(specs.size());
  std::mutex print_mutex;
  std::size_t finished = 0;
  parallel_for(o.jobs, specs.size(), [&](std::size_t i) {
    const RunSpec& s = specs[i];
    const GeneraliseLog& log = logs[s.log];
    RunResult& r = results[i];
    try {
      r = run_one(log, s, o);
    } catch (const std::exception& e) {
      r.error = e.what();
    }
    const std::lock_guard lock(print_mutex);
    ++finished;
    if (!r.error.empty()) {
      std::fprintf(stderr, "[%zu/%zu] %s k=%zu %s seed %llu FAILED: %s\n", finished, specs.size(),
                   log.name.c_str(), s.k, mode_name(s.mode),
                   static_cast<unsigned long long>(s.seed), r.error.c_str());
      return;
    }
    char relations[64] = "n/a";
    if (r.relations.result.matched > 0) {
      std::snprintf(relations, sizeof relations, "%.3f m", r.relations.result.trans_mean);
    }
    std::fprintf(stderr,
                 "[%zu/%zu] %s k=%zu %s seed %llu: %zu scans, derived %.3f m (%zu), relations %s "
                 "(%zu of %zu), %zu key scans, %zu loops, %.1f s\n",
                 finished, specs.size(), log.name.c_str(), s.k, mode_name(s.mode),
                 static_cast<unsigned long long>(s.seed), r.scans, r.derived.result.trans_mean,
                 r.derived.result.count, relations, r.relations.used, r.relations.total,
                 r.key_scans, r.loop_closures, r.run_s);
  });

  attach_floors(logs, specs, o.max_scans, results);
  if (!o.trajectories.empty()) {
    try {
      for (std::size_t i = 0; i < specs.size(); ++i) {
        if (results[i].error.empty()) {
          write_trajectory(o.trajectories, logs[specs[i].log], specs[i], o.max_scans,
                           results[i].estimate);
        }
      }
    } catch (const std::exception& e) {
      std::fprintf(stderr, "esfleet-bench generalise: %s\n", e.what());
      return app::kExitFailure;
    }
  }

  nlohmann::json runs = nlohmann::json::array();
  std::size_t failed = 0;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    if (!results[i].error.empty()) {
      ++failed;
      continue;
    }
    runs.push_back(run_json(logs[specs[i].log], specs[i], results[i]));
  }

  // Summary per (log, k, mode) over seeds, in run order.
  struct Group {
    std::size_t log = 0, k = 0;
    GeneraliseMode mode = GeneraliseMode::kLaserOnly;
    std::size_t scans = 0;
    std::vector<double> derived, relations, floor;
    std::size_t relations_used = 0;
    /// Per gap (kGaps' order), each run's mean translation error and its floor's; the
    /// derived relations' mean rotation error.
    std::vector<std::vector<double>> gap_derived, gap_floor;
    std::vector<double> rotation;
  };
  std::vector<Group> groups;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const RunSpec& s = specs[i];
    auto g = std::find_if(groups.begin(), groups.end(), [&](const Group& x) {
      return x.log == s.log && x.k == s.k && x.mode == s.mode;
    });
    if (g == groups.end()) {
      Group fresh;
      fresh.log = s.log;
      fresh.k = s.k;
      fresh.mode = s.mode;
      fresh.gap_derived.resize(kGaps.size());
      fresh.gap_floor.resize(kGaps.size());
      groups.push_back(std::move(fresh));
      g = groups.end() - 1;
    }
    const RunResult& r = results[i];
    if (!r.error.empty()) continue;
    g->scans = r.scans;
    if (r.derived.result.count > 0) g->derived.push_back(r.derived.result.trans_mean);
    if (r.relations.result.matched > 0) g->relations.push_back(r.relations.result.trans_mean);
    if (r.floor && r.floor->result.count > 0) g->floor.push_back(r.floor->result.trans_mean);
    g->relations_used = r.relations.used;
    if (r.derived.result.count > 0) g->rotation.push_back(r.derived.result.rot_mean_deg);
    for (std::size_t j = 0; j < kGaps.size(); ++j) {
      if (j < r.derived.result.gaps.size() && r.derived.result.gaps[j].count > 0) {
        g->gap_derived[j].push_back(r.derived.result.gaps[j].trans_mean);
      }
      if (r.floor && j < r.floor->result.gaps.size() && r.floor->result.gaps[j].count > 0) {
        g->gap_floor[j].push_back(r.floor->result.gaps[j].trans_mean);
      }
    }
  }
  nlohmann::json summary = nlohmann::json::array();
  for (const Group& g : groups) {
    nlohmann::json gaps = nlohmann::json::array();
    for (std::size_t j = 0; j < kGaps.size(); ++j) {
      gaps.push_back({{"gap", kGaps[j]},
                      {"trans_mean", range_json(range_of(g.gap_derived[j]))},
                      {"floor_trans_mean", range_json(range_of(g.gap_floor[j]))}});
    }
    summary.push_back({{"log", logs[g.log].name},
                       {"k", g.k},
                       {"mode", mode_name(g.mode)},
                       {"seeds", g.derived.size()},
                       {"scans", g.scans},
                       {"derived_trans_mean", range_json(range_of(g.derived))},
                       {"derived_floor_trans_mean", range_json(range_of(g.floor))},
                       {"relations_used", g.relations_used},
                       {"relations_trans_mean", range_json(range_of(g.relations))},
                       {"derived_rot_mean_deg", range_json(range_of(g.rotation))},
                       {"derived_gaps", gaps}});
  }
  nlohmann::json parameters = nlohmann::json::object();
  for (const auto& [name, value] : o.params.changed()) parameters[name] = value;
  nlohmann::json seed_list = seeds;
  const nlohmann::json out = {
      {"data_dir", o.data_dir},
      {"seeds", seed_list},
      {"max_scans", o.max_scans},
      {"beam_step", o.beam_step},
      {"sim",
       {{"rate", o.sim_rate},
        {"speed", o.sim_motion.speed},
        {"turn_rate_deg", o.sim_motion.turn_rate_deg},
        {"clearance",
         o.sim_clearance >= 0.0 ? nlohmann::json(o.sim_clearance) : nlohmann::json("per world")},
        {"beams", o.sim_laser.beams},
        {"fov_deg", o.sim_laser.fov_deg},
        {"max_range", o.sim_laser.max_range},
        {"range_noise", o.sim_laser.range_noise},
        {"dropout", o.sim_laser.dropout}}},
      {"paper", o.paper},
      {"changed_parameters", parameters},
      {"derived_gaps", kGaps},
      {"logs", log_info},
      {"noise",
       {{"distance_frac", o.noise.distance_frac},
        {"distance_base_m", o.noise.distance_base_m},
        {"turn_frac", o.noise.turn_frac},
        {"turn_base_deg", o.noise.turn_base_deg},
        {"turn_per_m_deg", o.noise.turn_per_m_deg}}},
      {"runs", runs},
      {"summary", summary}};
  try {
    write_file_atomically(o.output, out.dump(2) + "\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "esfleet-bench generalise: %s\n", e.what());
    return app::kExitFailure;
  }

  // The table: rows (log, k), columns per mode; derived mean and kept-ends relations mean.
  std::printf(
      "| log | k | scans | laser only: derived (m) | laser only: relations (m) | noisy odometry: "
      "derived (m) | noisy odometry: relations (m) |\n|---|---|---|---|---|---|---|\n");
  std::vector<std::pair<std::size_t, std::size_t>> rows;
  for (const Group& g : groups) {
    if (std::find(rows.begin(), rows.end(), std::pair{g.log, g.k}) == rows.end()) {
      rows.push_back({g.log, g.k});
    }
  }
  for (const auto& [l, k] : rows) {
    std::string cells;
    std::size_t scans = 0;
    for (GeneraliseMode mode : {GeneraliseMode::kLaserOnly, GeneraliseMode::kNoisyOdometry}) {
      const auto g = std::find_if(groups.begin(), groups.end(), [&](const Group& x) {
        return x.log == l && x.k == k && x.mode == mode;
      });
      if (g == groups.end()) {
        cells += " — | — |";
        continue;
      }
      scans = g->scans;
      const std::string floor = g->floor.empty() ? "" : " (floor " + cell(range_of(g->floor)) + ")";
      cells += " " + cell(range_of(g->derived)) + floor + " | " + cell(range_of(g->relations)) +
               " (" + std::to_string(g->relations_used) + ") |";
    }
    std::printf("| %s | %zu | %zu |%s\n", logs[l].name.c_str(), k, scans, cells.c_str());
  }
  const bool any_floor =
      std::any_of(groups.begin(), groups.end(), [](const Group& g) { return !g.floor.empty(); });
  // Per gap, the median over seeds, and the floor's where there is one: where a sparse run
  // loses accuracy (locally or over long stretches) and where it cannot be ranked.
  std::printf("\n| log | k | mode |");
  for (const std::size_t gap : kGaps) std::printf(" gap %zu |", gap);
  std::printf(" rotation |\n|---|---|---|");
  for (std::size_t j = 0; j < kGaps.size(); ++j) std::printf("---|");
  std::printf("---|\n");
  for (const auto& [l, k] : rows) {
    for (const Group& g : groups) {
      if (g.log != l || g.k != k) continue;
      std::string cells;
      for (std::size_t j = 0; j < kGaps.size(); ++j) {
        const Range d = range_of(g.gap_derived[j]);
        const Range f = range_of(g.gap_floor[j]);
        char buf[64] = "—";
        if (d.n > 0 && f.n > 0) {
          std::snprintf(buf, sizeof buf, "%.3f (%.3f)", d.median, f.median);
        } else if (d.n > 0) {
          std::snprintf(buf, sizeof buf, "%.3f", d.median);
        }
        cells += std::string(" ") + buf + " |";
      }
      const Range rot = range_of(g.rotation);
      char rotation[32] = "—";
      if (rot.n > 0) std::snprintf(rotation, sizeof rotation, "%.1f°", rot.median);
      std::printf("| %s | %zu | %s |%s %s |\n", logs[l].name.c_str(), k,
                  g.mode == GeneraliseMode::kLaserOnly ? "laser only" : "noisy odometry",
                  cells.c_str(), rotation);
    }
  }
  std::string gap_list;
  for (const std::size_t gap : kGaps) {
    gap_list += (gap_list.empty() ? "" : ", ") + std::to_string(gap);
  }
  std::printf(
      "\nFirst table: min–max over seeds of each run's mean translation error. derived: "
      "relations from the reference poses, gaps %s kept scans with a reference;%s relations: "
      "Kümmerle relations with both ends kept (count in brackets). Second table: the derived "
      "relations' mean translation error per gap (m) and mean rotation error, median over seeds"
      "%s. JSON: %s\n",
      gap_list.c_str(),
      any_floor ? " floor: the run on every scan of the same log (csail for csail-keys; same "
                  "mode and seed), its poses at the kept scans on the same derived relations "
                  "(the reference is GMapping's path: the score cannot rank runs below that);"
                : "",
      any_floor ? " (in brackets: the floor's median)" : "", o.output.c_str());
  std::fflush(stdout);
  if (failed > 0) {
    std::fprintf(stderr, "esfleet-bench generalise: %zu of %zu runs failed (see above)\n", failed,
                 specs.size());
    return app::kExitFailure;
  }
  return app::kExitOk;
}

}  // namespace esfleet::bench
