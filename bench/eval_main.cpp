// esfleet-eval: scores a trajectory file against a Kümmerle et al. (2009) .relations file.
//
// Exit codes: 0 success; 1 nothing matched (a warning says why that usually happens);
// 2 usage error, unreadable or malformed input.

#include <cmath>
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "esfleet/core/relations.hpp"
#include "esfleet/core/trajectory_io.hpp"

namespace {

constexpr int kExitNoMatch = 1;
constexpr int kExitError = 2;

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
    "Example (Freiburg 079: relation stamps = log stamps + 1211.45 s):\n"
    "  esfleet-eval --trajectory fr079.traj --relations fr079.relations --time-offset 1211.45\n"
    "\n"
    "Exit codes: 0 ok, 1 no relation matched (the JSON statistics are then null),\n"
    "2 usage error or bad input file.";

std::string format(const char* fmt, double a, double b) {
  char buf[128];
  std::snprintf(buf, sizeof buf, fmt, a, b);
  return buf;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{kDescription, "esfleet-eval"};
  std::string trajectory_path, relations_path;
  esfleet::RelationsOptions options;
  bool json = false;
  app.add_option("--trajectory", trajectory_path, "trajectory file, \"t x y theta\" per line")
      ->required();
  app.add_option("--relations", relations_path,
                 "relations file, \"t1 t2 x y z roll pitch yaw\" per line")
      ->required();
  app.add_option("--time-offset", options.time_offset,
                 "seconds added to trajectory stamps to get relation stamps (fr079: 1211.45)")
      ->capture_default_str();
  app.add_option("--tolerance", options.tolerance,
                 "max seconds between a relation stamp and its nearest trajectory pose")
      ->capture_default_str();
  app.add_option("--outlier-trans", options.outlier_trans,
                 "relations with a larger translation error count as outliers, metres")
      ->capture_default_str();
  app.add_option("--outlier-rot", options.outlier_rot_deg,
                 "relations with a larger rotation error count as outliers, degrees")
      ->capture_default_str();
  app.add_flag("--json", json, "also print the result as one JSON object on the last line");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help
    std::cerr << "esfleet-eval: " << e.what() << " (run with --help for usage)\n";
    return kExitError;
  }

  // Checked here rather than with CLI11 validators, whose messages print DBL_MAX in full.
  if (!std::isfinite(options.time_offset)) {
    std::cerr
        << "esfleet-eval: --time-offset must be a finite number (run with --help for usage)\n";
    return kExitError;
  }
  if (!std::isfinite(options.tolerance) || options.tolerance < 0.0) {
    std::cerr << "esfleet-eval: --tolerance must be a finite number >= 0 (run with --help for "
                 "usage)\n";
    return kExitError;
  }

  try {
    const auto trajectory = esfleet::read_trajectory(trajectory_path);
    const auto relations = esfleet::read_relations(relations_path);
    const esfleet::RelationsResult r = esfleet::evaluate_relations(trajectory, relations, options);

    if (r.matched > 0) {
      std::cout << "translation: " << format("%.4f \u00b1 %.4f m", r.trans_mean, r.trans_std)
                << '\n'
                << "rotation: " << format("%.2f \u00b1 %.2f deg", r.rot_mean_deg, r.rot_std_deg)
                << '\n';
    } else {
      std::cout << "translation: n/a\nrotation: n/a\n";
    }
    std::cout << "matched: " << r.matched << " / " << r.total << " relation lines\n";
    if (r.matched > 0) {
      std::cout << "worst: "
                << format("%.3f m, outliers (> %g m", r.trans_max, options.outlier_trans) << " or "
                << options.outlier_rot_deg << " deg): " << r.outliers << '\n';
    }
    if (json) {
      // With nothing matched the statistics are undefined: null, not a misleading 0.
      const auto stat = [&](double v) { return r.matched > 0 ? nlohmann::json(v) : nullptr; };
      const nlohmann::json j = {{"trans_mean", stat(r.trans_mean)},
                                {"trans_std", stat(r.trans_std)},
                                {"rot_mean_deg", stat(r.rot_mean_deg)},
                                {"rot_std_deg", stat(r.rot_std_deg)},
                                {"trans_max", stat(r.trans_max)},
                                {"outliers", r.outliers},
                                {"matched", r.matched},
                                {"total", r.total}};
      std::cout << j.dump() << '\n';
    }
    std::cout.flush();
    if (r.matched == 0) {
      std::cerr << "esfleet-eval: warning: no relation matched a trajectory pose within "
                << options.tolerance << " s (" << trajectory.size() << " poses, " << r.total
                << " relations); check --time-offset and that both files cover the same run\n";
      return kExitNoMatch;
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "esfleet-eval: error: " << e.what() << '\n';
    return kExitError;
  }
}
