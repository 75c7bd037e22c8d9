#include "app/localise_params.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace esfleet::app {

void add_localise_params(ParamTable& t, LocaliserConfig* c) {
  t.add_enum<GlobalSearchMethod>(
      "localise_search", &c->search.method,
      {{"grid", GlobalSearchMethod::kGrid}, {"es", GlobalSearchMethod::kEs}},
      "global search: grid = coarse exhaustive scoring then ES refinement (ours); es = the ES "
      "alone from a population spread over free space, with restarts (the paper's way)");
  t.add_int("localise_coarse_level", &c->search.coarse_level,
            "map pyramid level scored exhaustively by the grid search (3 = 0.4 m cells)");
  t.add_double("localise_step_xy", &c->search.step_xy,
               "grid search position step, metres (0 = 3/4 of a coarse cell)");
  t.add_double("localise_step_theta", &c->search.step_theta_deg,
               "grid search heading step, degrees (0 = a coarse cell at the median range)");
  t.add_int("localise_coarse_points", &c->search.coarse_points,
            "end points used for coarse scoring");
  t.add_enum<CoarseScore>(
      "localise_coarse_score", &c->search.coarse_score,
      {{"fitness", CoarseScore::kFitness},
       {"sum", CoarseScore::kSum},
       {"both", CoarseScore::kBoth}},
      "grid search: rank the coarse poses by the paper's fitness, by the sum of map values "
      "(without the penalty p_occ), or keep the best by each");
  t.add_double("localise_free_max", &c->search.free_max_value,
               "a cell is free space (a start candidate) when hit/(hit+err) is at most this");
  t.add_int("localise_candidates", &c->search.candidates,
            "distinct candidates kept per global search");
  t.add_int("localise_es_restarts", &c->search.es_restarts, "es search: ES runs per global search");
  t.add_int("localise_es_iterations", &c->search.es_iterations, "es search: iterations per ES run");
  t.add_int("localise_confirm_scans", &c->confirm_scans,
            "consecutive well-matching scans before a pose is declared");
  t.add_double("localise_min_agreement", &c->min_agreement,
               "a well-matching scan puts at least this share of its known end points on "
               "occupied cells");
  t.add_double("localise_min_known", &c->min_known,
               "... and at least this share of all end points on known cells");
  t.add_double("localise_min_travel", &c->min_travel,
               "a pose is declared only after moving this far, metres (or turning min_turn)");
  t.add_double("localise_min_turn", &c->min_turn_deg, "... or turning this much, degrees");
  t.add_double("localise_max_ambiguity", &c->max_ambiguity,
               "a pose is declared only if the best rival scores below this share of it");
  t.add_int("localise_max_hypotheses", &c->max_hypotheses, "hypotheses followed at once");
  t.add_int("localise_research_every", &c->research_every,
            "scans without a declaration between global searches");
  t.add_int("localise_research_every_max", &c->research_every_max,
            "each search after which nothing matches well doubles that wait, up to this many "
            "scans (= research_every: no backoff)");
  t.add_switch("localise_verify", &c->verify,
               "search globally once more before declaring a pose; a rival explaining the scan "
               "nearly as well delays the declaration");
  t.add_double("localise_verify_ambiguity", &c->verify_ambiguity,
               "final check: a pose elsewhere whose evidence on the scan reaches this share of "
               "the leader's delays the declaration");
  t.add_switch("localise_local_check", &c->local_check,
               "before declaring, move the pose to a clearly better-fitting one within 0.5 m / "
               "3 deg and confirm again");
  t.add_double("localise_contradiction_factor", &c->contradiction_factor,
               "a hypothesis is also clear of a rival with this many times its share of end "
               "points on known free cells, plus the margin (0 = off: evidence ratio only)");
  t.add_double("localise_contradiction_margin", &c->contradiction_margin, "... plus this share");
  t.add_double("localise_contradiction_min_agreement", &c->contradiction_min_agreement,
               "... if its own mean agreement reaches this");
  t.add_double("localise_contradiction_min_known", &c->contradiction_min_known,
               "... and its mean share of end points on known cells this");
  t.add_int("localise_contradiction_min_streak", &c->contradiction_min_streak,
            "... and its good streak this many scans");
  t.add_int("localise_hypothesis_iterations", &c->hypothesis_iterations,
            "ES iterations per scan for each hypothesis while localising");
  t.add_double("localise_prune_ratio", &c->prune_ratio,
               "hypotheses whose mean evidence falls below this share of the best drop out");
  t.add_int("localise_hint_scans", &c->hint_scans,
            "a hint that yields no pose within this many scans widens to the global search");
  t.add_double("lost_agreement", &c->lost_agreement,
               "tracking: a scan whose agreement is below this is bad");
  t.add_double("lost_known", &c->lost_known,
               "tracking: ... or whose share of end points on known cells is below this");
  t.add_int("lost_scans", &c->lost_scans, "consecutive bad scans that mean lost (relocalise)");
  t.add_double("localise_motion_hold", &c->motion_hold,
               "tracking: move the pose along the direction the map constrains least onto the "
               "motion hypothesis if the fitness there is within this share of the found one "
               "(0 = off)");
}

PoseHint parse_hint(const std::string& text) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      const double d = std::stod(item, &used);
      if (used != item.size() || !std::isfinite(d)) throw std::invalid_argument(item);
      v.push_back(d);
    } catch (const std::exception&) {
      throw std::invalid_argument("hint '" + text + "': '" + item + "' is not a number");
    }
  }
  if (v.size() < 3 || v.size() > 5) {
    throw std::invalid_argument("hint '" + text +
                                "': expected x,y,theta_deg[,radius_m[,angle_deg]]");
  }
  PoseHint h;
  h.pose = {v[0], v[1], normalize_angle(deg_to_rad(v[2]))};
  if (v.size() > 3) h.radius = v[3];
  if (v.size() > 4) h.angle_deg = v[4];
  if (h.radius < 0.0) throw std::invalid_argument("hint '" + text + "': radius must be >= 0");
  if (h.angle_deg < 0.0 || h.angle_deg > 180.0) {
    throw std::invalid_argument("hint '" + text + "': angle must be in [0, 180] degrees");
  }
  return h;
}

}  // namespace esfleet::app
