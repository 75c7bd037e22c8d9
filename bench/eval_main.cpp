// esfleet-eval: scores a trajectory file against a Kümmerle et al. (2009) .relations file, and
// against a corrected log's poses (the absolute error: how bent or scaled the whole map is).
//
// Exit codes: 0 success; 1 nothing matched (a warning says why that usually happens);
// 2 usage error, unreadable or malformed input.

#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "app/program.hpp"
#include "esfleet/core/carmen_reader.hpp"
#include "esfleet/core/relations.hpp"
#include "esfleet/core/trajectory_io.hpp"
#include "generalise_data.hpp"

namespace {

using esfleet::app::UsageError;

constexpr const char* kDescription =
    "Scores an estimated trajectory with the relations metric of Kummerle et al., \"On\n"
    "measuring the accuracy of SLAM algorithms\" (2009). Each relations line\n"
    "\"t1 t2 x y z roll pitch yaw\" is a ground-truth pose at t2 seen from the pose at t1.\n"
    "For each line the trajectory poses nearest to t1 and t2 (within --tolerance, after\n"
    "subtracting --time-offset) give est = inv(P1)*P2 and err = inv(rel)*est; the program\n"
    "reports mean +- population std of the translation error |err.xy| (m) and of the\n"
    "absolute rotation error (deg), and how many lines were matched.\n"
    "\n"
    "The trajectory file has one \"t x y theta\" line per pose (s, m, m, rad).\n"
    "\n"
    "With --reference, a CARMEN log of the same run whose odometry fields are corrected\n"
    "poses, it also reports the absolute error: the trajectory is moved onto those poses by\n"
    "the best rotation and translation, and the position errors left (RMS, mean, max) show\n"
    "how bent the whole map is, which relations between nearby moments hardly see; the best\n"
    "scale as well (> 1: the map is smaller than the reference). A key-scan log (e.g.\n"
    "csail-corrected.log.gz) takes its stamps from the raw log given as --reference-raw,\n"
    "matched by identical ranges. A trajectory of a run on such a log (its own stamps\n"
    "rounded) is scored with --by-index: its poses take the stamps of the reference's scans.\n"
    "\n"
    "Examples (Freiburg 079: relation stamps = log stamps + 1211.45 s):\n"
    "  esfleet-eval --trajectory fr079.traj --relations fr079.relations --time-offset 1211.45\n"
    "  esfleet-eval --trajectory fr079.traj --reference fr079-corrected.log.gz\n"
    "  esfleet-eval --trajectory csail.traj --relations mit-csail.relations \\\n"
    "      --reference csail-corrected.log.gz --reference-raw mit-csail.clf.gz\n"
    "  esfleet-eval --trajectory keys.traj --relations mit-csail.relations --by-index \\\n"
    "      --reference csail-corrected.log.gz --reference-raw mit-csail.clf.gz";

struct EvalOptions {
  std::string trajectory;            ///< "t x y theta" per line (required)
  std::string relations;             ///< "t1 t2 x y z roll pitch yaw" per line
  std::string reference;             ///< CARMEN log with corrected poses in its odometry fields
  std::string reference_raw;         ///< the raw log a key-scan --reference was taken from
  esfleet::RelationsOptions metric;  ///< time offset, tolerance, outlier thresholds
  bool by_index = false;             ///< trajectory pose i is --reference scan i
  bool json = false;                 ///< also print the result as one JSON line
  double split_gap = 0.0;  ///< > 0: also score relations with t2 - t1 below / at least this apart

  /// Throws UsageError naming the flag. Checked here rather than with CLI11 validators, whose
  /// messages print DBL_MAX in full.
  void validate() const {
    if (relations.empty() && reference.empty()) {
      throw UsageError("give --relations, --reference or both");
    }
    if (by_index && reference.empty()) {
      throw UsageError("--by-index needs --reference (the log the trajectory was made from)");
    }
    if (!reference_raw.empty() && reference.empty()) {
      throw UsageError("--reference-raw needs --reference (the key-scan log)");
    }
    if (!std::isfinite(metric.time_offset)) {
      throw UsageError("--time-offset must be a finite number");
    }
    if (!std::isfinite(metric.tolerance) || metric.tolerance < 0.0) {
      throw UsageError("--tolerance must be a finite number >= 0");
    }
    if (!std::isfinite(split_gap) || split_gap < 0.0) {
      throw UsageError("--split-gap must be a finite number >= 0");
    }
  }
};

void add_eval_flags(CLI::App& app, EvalOptions& o) {
  app.add_option("--trajectory", o.trajectory, "trajectory file, \"t x y theta\" per line")
      ->required();
  app.add_option("--relations", o.relations,
                 "relations file, \"t1 t2 x y z roll pitch yaw\" per line");
  app.add_option("--reference", o.reference,
                 "CARMEN log of the same run with corrected poses in its odometry fields: also "
                 "score the absolute error");
  app.add_option("--reference-raw", o.reference_raw,
                 "the raw log a key-scan --reference was taken from: its scans' stamps, matched "
                 "by identical ranges");
  app.add_flag("--by-index", o.by_index,
               "the trajectory's poses are --reference's scans in order (a run on that log): "
               "they take its stamps (with --reference-raw, the raw log's) instead of their own, "
               "e.g. a run on a log whose stamps were printed rounded");
  app.add_option("--time-offset", o.metric.time_offset,
                 "seconds added to trajectory stamps to get relation stamps (fr079: 1211.45)")
      ->capture_default_str();
  app.add_option("--tolerance", o.metric.tolerance,
                 "max seconds between a relation stamp and its nearest trajectory pose")
      ->capture_default_str();
  app.add_option("--outlier-trans", o.metric.outlier_trans,
                 "relations with a larger translation error count as outliers, metres")
      ->capture_default_str();
  app.add_option("--outlier-rot", o.metric.outlier_rot_deg,
                 "relations with a larger rotation error count as outliers, degrees")
      ->capture_default_str();
  app.add_option("--split-gap", o.split_gap,
                 "seconds; > 0: also score the relations with t2 - t1 below it (local) and at "
                 "least it (revisits: loop closure) apart, separately")
      ->capture_default_str();
  app.add_flag("--json", o.json, "also print the result as one JSON object on the last line");
}

std::string format(const char* fmt, double a, double b) {
  char buf[128];
  std::snprintf(buf, sizeof buf, fmt, a, b);
  return buf;
}

/// One part of the relations split by --split-gap, scored on its own.
struct SplitPart {
  const char* name;   ///< "local" or "revisits"
  const char* range;  ///< how t2 - t1 compares with the gap: "<" or ">="
  esfleet::RelationsResult result;
};

/// A statistic of `r` for the JSON: null when nothing matched (undefined, not a misleading 0).
nlohmann::json stat(const esfleet::RelationsResult& r, double v) {
  return r.matched > 0 ? nlohmann::json(v) : nullptr;
}

/// The relations with t2 - t1 below `gap` (local) and at least `gap` (revisits), each scored.
std::vector<SplitPart> score_split(const std::vector<esfleet::TimedPose>& trajectory,
                                   const std::vector<esfleet::Relation>& relations, double gap,
                                   const esfleet::RelationsOptions& metric) {
  std::vector<esfleet::Relation> local, revisits;
  for (const auto& rel : relations) (rel.t2 - rel.t1 < gap ? local : revisits).push_back(rel);
  return {{"local", "<", esfleet::evaluate_relations(trajectory, local, metric)},
          {"revisits", ">=", esfleet::evaluate_relations(trajectory, revisits, metric)}};
}

/// Poses are matched by time: when more than a tenth of `poses` are not stamped after the pose
/// before them (rounded stamps: a key-scan log printed with 6 digits), throws naming `what`
/// and `remedy`; fewer only warn.
void check_stamps(const std::vector<esfleet::TimedPose>& poses, const std::string& what,
                  const std::string& remedy) {
  std::vector<double> stamps;
  stamps.reserve(poses.size());
  for (const esfleet::TimedPose& p : poses) stamps.push_back(p.stamp);
  const esfleet::StampOrder order = esfleet::stamp_order(stamps);
  if (order.not_after == 0) return;
  const std::string text = what + ": " + std::to_string(order.not_after) + " of " +
                           std::to_string(poses.size()) +
                           " poses are not stamped after the pose before them (the first: pose " +
                           std::to_string(order.first + 1) + ")";
  if (order.not_after * 10 > poses.size()) {
    throw std::runtime_error(text + "; rounded stamps? Poses are matched by time" + remedy);
  }
  spdlog::warn("{}", text);
}

/// The poses of --reference in the trajectory's time base: a key-scan log takes the stamps of
/// the --reference-raw scans it was taken from. Throws std::runtime_error naming the file.
std::vector<esfleet::TimedPose> read_reference(const EvalOptions& o) {
  const std::vector<esfleet::LaserScan> scans = esfleet::read_carmen_log(o.reference);
  std::vector<esfleet::LaserScan> raw;
  std::vector<std::size_t> match;
  if (!o.reference_raw.empty()) {
    raw = esfleet::read_carmen_log(o.reference_raw);
    match = esfleet::bench::match_key_scans(scans, raw, o.reference, o.reference_raw);
  }
  std::vector<esfleet::TimedPose> reference;
  reference.reserve(scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (!scans[i].odometry) {
      throw std::runtime_error(o.reference + ": laser scan " + std::to_string(i + 1) +
                               " has no pose fields (a corrected pose is needed)");
    }
    reference.push_back({match.empty() ? scans[i].stamp : raw[match[i]].stamp, *scans[i].odometry});
  }
  check_stamps(reference, o.reference,
               match.empty() ? "; a key-scan log takes its stamps from --reference-raw" : "");
  return reference;
}

/// Prints the relations scores.
void print_relations(const EvalOptions& o, const esfleet::RelationsResult& r,
                     const std::vector<SplitPart>& split) {
  if (r.matched > 0) {
    std::cout << "translation: " << format("%.4f \u00b1 %.4f m", r.trans_mean, r.trans_std) << '\n'
              << "rotation: " << format("%.2f \u00b1 %.2f deg", r.rot_mean_deg, r.rot_std_deg)
              << '\n';
  } else {
    std::cout << "translation: n/a\nrotation: n/a\n";
  }
  std::cout << "matched: " << r.matched << " / " << r.total << " relation lines\n";
  if (r.matched > 0) {
    std::cout << "worst: "
              << format("%.3f m, outliers (> %g m", r.trans_max, o.metric.outlier_trans) << " or "
              << o.metric.outlier_rot_deg << " deg): " << r.outliers << '\n';
  }
  for (const auto& part : split) {
    const auto& p = part.result;
    std::cout << part.name << " (t2 - t1 " << part.range << ' ' << o.split_gap << " s): ";
    if (p.matched > 0) {
      std::cout << format("translation %.4f \u00b1 %.4f m", p.trans_mean, p.trans_std)
                << format(", rotation %.2f \u00b1 %.2f deg", p.rot_mean_deg, p.rot_std_deg);
    } else {
      std::cout << "n/a";
    }
    std::cout << ", matched " << p.matched << " / " << p.total << '\n';
  }
}

nlohmann::json relations_json(const EvalOptions& o, const esfleet::RelationsResult& r,
                              const std::vector<SplitPart>& split) {
  nlohmann::json j = {{"trans_mean", stat(r, r.trans_mean)},
                      {"trans_std", stat(r, r.trans_std)},
                      {"rot_mean_deg", stat(r, r.rot_mean_deg)},
                      {"rot_std_deg", stat(r, r.rot_std_deg)},
                      {"trans_max", stat(r, r.trans_max)},
                      {"outliers", r.outliers},
                      {"matched", r.matched},
                      {"total", r.total}};
  for (const auto& part : split) {
    const auto& p = part.result;
    j["split"][part.name] = {{"trans_mean", stat(p, p.trans_mean)},
                             {"rot_mean_deg", stat(p, p.rot_mean_deg)},
                             {"matched", p.matched},
                             {"total", p.total}};
  }
  if (!split.empty()) j["split"]["gap_s"] = o.split_gap;
  return j;
}

/// Prints the scores; 0, or 1 when no relation (or fewer than two reference poses) matched.
int evaluate(const EvalOptions& o) {
  std::vector<esfleet::TimedPose> trajectory;
  esfleet::RelationsResult r;
  std::vector<SplitPart> split;
  esfleet::AbsoluteErrorResult a;
  try {
    trajectory = esfleet::read_trajectory(o.trajectory);
    const std::vector<esfleet::TimedPose> reference =
        o.reference.empty() ? std::vector<esfleet::TimedPose>{} : read_reference(o);
    if (o.by_index) {
      if (trajectory.size() != reference.size()) {
        throw std::runtime_error("--by-index: " + o.trajectory + " has " +
                                 std::to_string(trajectory.size()) + " poses but " + o.reference +
                                 " has " + std::to_string(reference.size()) + " laser scans");
      }
      for (std::size_t i = 0; i < trajectory.size(); ++i) trajectory[i].stamp = reference[i].stamp;
    } else {
      check_stamps(trajectory, o.trajectory,
                   ", so this trajectory cannot be scored (--by-index takes the stamps of the "
                   "--reference log it was made from)");
    }
    if (!o.relations.empty()) {
      const auto relations = esfleet::read_relations(o.relations);
      r = esfleet::evaluate_relations(trajectory, relations, o.metric);
      if (o.split_gap > 0.0) split = score_split(trajectory, relations, o.split_gap, o.metric);
    }
    if (!o.reference.empty()) {
      a = esfleet::evaluate_absolute(trajectory, reference, o.metric.tolerance);
    }
  } catch (const std::exception& e) {
    throw UsageError(e.what());  // bad input: "<path>:<line>: ..."
  }
  if (!o.relations.empty()) print_relations(o, r, split);
  const bool absolute = a.matched >= 2;
  if (!o.reference.empty()) {
    std::cout << "absolute: ";
    if (absolute) {
      std::cout << format("rms %.3f m, mean %.3f m", a.rms, a.mean)
                << format(", max %.3f m; scale %.4f", a.max, a.scale)
                << format(" (rms %.3f m with it)", a.rms_scaled, 0.0);
    } else {
      std::cout << "n/a";
    }
    std::cout << ", matched " << a.matched << " / " << a.total << " reference poses\n";
  }
  if (o.json) {
    nlohmann::json j = o.relations.empty() ? nlohmann::json::object() : relations_json(o, r, split);
    if (!o.reference.empty()) {
      auto v = [&](double x) { return absolute ? nlohmann::json(x) : nullptr; };
      j["absolute"] = {{"rms", v(a.rms)},
                       {"mean", v(a.mean)},
                       {"max", v(a.max)},
                       {"scale", v(a.scale)},
                       {"rms_scaled", v(a.rms_scaled)},
                       {"matched", a.matched},
                       {"total", a.total}};
    }
    std::cout << j.dump() << '\n';
  }
  std::cout.flush();
  int code = esfleet::app::kExitOk;
  if (!o.relations.empty() && r.matched == 0) {
    spdlog::warn(
        "no relation matched a trajectory pose within {} s ({} poses, {} relations); check "
        "--time-offset and that both files cover the same run",
        o.metric.tolerance, trajectory.size(), r.total);
    code = esfleet::app::kExitFailure;
  }
  if (!o.reference.empty() && !absolute) {
    spdlog::warn(
        "{} of {} reference poses matched a trajectory pose within {} s (2 needed); check that "
        "both files cover the same run (a key-scan log needs --reference-raw)",
        a.matched, a.total, o.metric.tolerance);
    code = esfleet::app::kExitFailure;
  }
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  esfleet::app::Program program("esfleet-eval", "eval", kDescription,
                                "1 also when no relation matched, or fewer than two reference "
                                "poses (the JSON statistics are then null)");
  EvalOptions o;
  add_eval_flags(program.cli(), o);
  if (auto code = program.parse(argc, argv)) return *code;
  return program.run([&] {
    o.validate();
    return evaluate(o);
  });
}
