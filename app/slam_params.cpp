#include "app/slam_params.hpp"

#include <set>
#include <string>

namespace esfleet::app {

void add_slam_params(ParamTable& t, SlamConfig* s, CarmenReaderOptions* r) {
  // Map (paper Eq. 2, Algorithm 1).
  t.add_double("cell_size", &s->map.cell_size, "grid cell edge alpha^Map, metres");
  t.add_int("tile_edge", &s->map.tile_edge, "cells per tile edge (power of two)");
  t.add_switch("exact_traversal", &s->update.exact_traversal,
               "map update walks every crossed cell (off: the paper's ceil(alpha_res*d) samples)");
  t.add_double("alpha_res", &s->update.alpha_res,
               "samples per metre along a beam when exact_traversal is off (paper alpha^Res)");
  t.add_double("no_return_clear_range", &s->update.no_return_clear_range,
               "no-return beams clear cells up to this range, metres (0 = not at all)");
  t.add_double("write_range", &s->update.write_range,
               "end points farther than this are not written into the map: their beams clear "
               "cells up to this range and hit none, metres (at most 1000; GMapping's maxUrange; "
               "the matching still uses them)");
  t.add_double("free_margin", &s->update.free_margin,
               "a beam clears the cells it crosses up to this short of its end point, metres "
               "(0 = every crossed cell, the paper)");
  t.add_double("beam_fill", &s->update.beam_fill_deg,
               "a laser coarser than this is written into the map with end points added "
               "between adjacent beams of one surface, down to this spacing, degrees (0 = off, "
               "the paper; matching uses the scan's own beams; a 0.5 deg laser is unchanged)");
  t.add_double("beam_fill_max_gap", &s->update.beam_fill_max_gap,
               "beam fill: only between adjacent beams whose ranges differ by at most this, "
               "metres");
  t.add_double("beam_fill_min_step", &s->update.beam_fill_min_step,
               "beam fill: only while the scans are far apart, this scan's step or one of the "
               "5 before moving at least this, metres, or turning --beam-fill-min-turn (both 0 "
               "= every scan)");
  t.add_double("beam_fill_min_turn", &s->update.beam_fill_min_turn_deg,
               "beam fill: ... or turning at least this, degrees");
  // ES (paper Eq. 9, Table 2).
  t.add_int("mu", &s->tracking.es.mu, "ES parents");
  t.add_int("iterations", &s->tracking.es.iterations, "ES iterations T per scan (one child each)");
  t.add_double("alpha_xy", &s->tracking.es.alpha_xy, "mutation coefficient alpha_1 = alpha_2, cm");
  t.add_double("alpha_theta", &s->tracking.es.alpha_theta, "mutation coefficient alpha_3, degrees");
  t.add_double("beta", &s->tracking.es.beta,
               "mutation offset beta (cm for x, y; degrees for theta)");
  t.add_switch("penalty", &s->tracking.use_penalty,
               "fitness with the penalty p_occ (paper Condition 1); off = Condition 2");
  // Pipeline.
  t.add_switch("odometry", &s->tracking.use_odometry, "predict with the log's odometry increments");
  t.add_enum<MotionPrediction>("prediction", &s->tracking.prediction,
                               {{"previous", MotionPrediction::kPreviousPose},
                                {"constant-velocity", MotionPrediction::kConstantVelocity}},
                               "pose prediction without odometry");
  t.add_float("min_range", &s->tracking.min_range, "ignore beams shorter than this, metres");
  t.add_float("max_range", &s->tracking.max_range,
              "ignore beams at or beyond this, metres (0 = all)");
  t.add_double("init_sigma_xy", &s->tracking.init_sigma_xy,
               "initial population spread around the prediction, metres");
  t.add_double("init_sigma_theta", &s->tracking.init_sigma_theta_deg,
               "initial population spread around the prediction, degrees");
  t.add_u64("seed", &s->seed, "random seed of the ES (same input + seed = same output)");
  // Beyond the paper.
  t.add_switch("motion_hypotheses", &s->tracking.motion_hypotheses,
               "put every motion hypothesis (previous pose, constant velocity, odometry) into "
               "the initial population");
  t.add_switch("turn_hypotheses", &s->tracking.turn_hypotheses,
               "laser only: also hypotheses turning +-1 and +-2 times the last turn");
  t.add_enum<Interpolation>("interpolation", &s->tracking.interpolation,
                            {{"none", Interpolation::kNone},
                             {"polish", Interpolation::kPolish},
                             {"all", Interpolation::kAll}},
                            "bilinear sub-cell map values in the fitness: nowhere, in the final "
                            "polish, or also in the ES");
  t.add_double("search_point_spacing", &s->tracking.search_point_spacing,
               "the ES scores only end points at least this far from the previous one it "
               "kept, metres (0 = every end point, the paper); the polish scores all");
  t.add_switch("refine", &s->tracking.refine,
               "polish the ES result with a deterministic pattern search");
  t.add_double("prior_sigma_xy", &s->tracking.prior_sigma_xy,
               "motion prior width, metres (0 = no prior)");
  t.add_double("prior_sigma_theta", &s->tracking.prior_sigma_theta_deg,
               "motion prior width, degrees (0 = no prior)");
  t.add_switch("prior_on_stop", &s->tracking.prior_on_stop,
               "laser only: the prior also favours the previous pose (a stop)");
  t.add_double("motion_hold", &s->tracking.motion_hold,
               "after the search, move the pose along the direction the map constrains least "
               "onto the motion hypothesis if the fitness there is within this share of the "
               "found one (0 = off; the follower's is localise_motion_hold)");
  t.add_double("motion_hold_ratio", &s->tracking.motion_hold_ratio,
               "... only where the fitness's least curvature is at most this share of its "
               "greatest (a corridor; 1 = everywhere)");
  t.add_double("insert_min_travel", &s->insert_min_travel,
               "insert a scan once the robot moved this far since the last one, metres (0 and "
               "insert_min_turn 0 = every scan)");
  t.add_double("insert_min_turn", &s->insert_min_turn_deg, "... or turned this much, degrees");
  t.add_double("short_view_range", &s->short_view_range,
               "with odometry: while no scan in the map had a beam this long (a short laser), "
               "hold along the motion with at least --short-view-motion-hold, metres (0 = off)");
  t.add_double("short_view_motion_hold", &s->short_view_motion_hold,
               "... the motion hold then (as --motion-hold)");
  t.add_switch("loop_closure", &s->loop.enabled, "loop closure over a pose graph");
  t.add_double("loop_move_min_xy", &s->loop.move_min_xy,
               "after a loop closure, re-write a scan into the map only if it moved this far, "
               "metres");
  t.add_double("loop_move_min_theta", &s->loop.move_min_theta_deg,
               "... or turned this much, degrees");
  t.add_int("loop_every", &s->loop.every, "attempt a loop closure every N inserted scans");
  t.add_int("loop_defer", &s->loop.defer_keys,
            "search a loop closure on a worker thread and apply it N inserted scans later "
            "(deterministic; 0 = apply at the scan that started it, see loop_speculate)");
  t.add_switch("loop_speculate", &s->loop.speculate,
               "loop_defer 0: search on a worker thread while the next scans are processed; "
               "an accepted closure undoes and re-processes them (the same result as off, "
               "where the mapping thread searches)");
  t.add_int("loop_cooldown", &s->loop.cooldown,
            "no loop-closure attempt for N inserted scans after an accepted one");
  t.add_double("loop_min_travel", &s->loop.min_travel,
               "a loop closes against scans at least this far back along the path, metres");
  t.add_double("loop_search_radius", &s->loop.search_radius,
               "old scans this close to the estimate trigger an attempt, metres");
  t.add_double("loop_window_xy", &s->loop.window_xy, "loop search window +-, metres");
  t.add_double("loop_window_max_xy", &s->loop.window_max_xy,
               "the loop search window grows with the plausible drift (loop_min_travel's scan "
               "distance) up to this, metres (at most loop_window_xy: fixed)");
  t.add_double("loop_window_theta", &s->loop.window_theta_deg, "loop search window +-, degrees");
  t.add_double("loop_min_agreement", &s->loop.min_agreement,
               "share of end points on occupied cells a loop match needs");
  t.add_double("loop_max_ambiguity", &s->loop.max_ambiguity,
               "second-best distinct score / best score a loop match may have");
  t.add_switch("loop_final", &s->loop.final_pass,
               "when the input ends, match every inserted scan against the ones near it from "
               "other times and re-optimise the graph");
  t.add_int("loop_final_every", &s->loop.final_every, "final pass: match every N-th inserted scan");
  t.add_int("loop_final_rounds", &s->loop.final_rounds,
            "final pass: rounds of matching, each from the poses the last one optimised");
  t.add_double("loop_final_window_xy", &s->loop.final_window_xy,
               "final pass search window +-, metres");
  t.add_double("loop_final_window_theta", &s->loop.final_window_theta_deg,
               "final pass search window +-, degrees");
  t.add_double("loop_final_radius", &s->loop.final_submap_radius,
               "final pass: scans from other times within this of a scan form its submap, metres");
  t.add_int("loop_final_max_scans", &s->loop.final_max_submap_scans,
            "final pass: at most this many scans (nearest first) in a submap");
  t.add_double("loop_final_max_chi2", &s->loop.final_max_edge_chi2,
               "final pass: matches the optimised graph disagrees with by more than this "
               "(whitened squared error) are dropped");
  t.add_double("loop_final_max_ambiguity", &s->loop.final_max_ambiguity,
               "final pass: second-best distinct score / best score a match may have");
  t.add_double("loop_final_rival_distance", &s->loop.final_rival_distance,
               "final pass: what counts as distinct for the ambiguity, metres");
  t.add_double("loop_final_degenerate_ratio", &s->loop.final_degenerate_ratio,
               "final pass: a match whose position the submap constrains along one direction "
               "less than this share of the other (a corridor's axis) keeps the graph's "
               "position along it (0 = off)");
  t.add_int("loop_final_icp_neighbours", &s->loop.final_icp_neighbours,
            "final pass: align each inserted scan to the N inserted before it (point-to-line "
            "ICP); the graph takes the alignments that hold as edges (0 = off)");
  t.add_double("loop_final_icp_max_distance", &s->loop.final_icp_max_distance,
               "final pass: scans farther apart than this are not aligned by ICP, metres");
  t.add_double("loop_final_icp_degenerate_ratio", &s->loop.icp.degenerate_ratio,
               "final pass ICP: a direction the scans constrain less than this share of the "
               "best-constrained one keeps the tracked motion (a corridor's axis; 0 = off)");
  t.add_double("loop_final_icp_min_normal_cos", &s->loop.icp.min_normal_cos,
               "final pass ICP: an end point pairs only with a line whose normal is within "
               "acos(this) of its own line's (0 = off: every end point may pair)");
  t.add_double("loop_max_chi2", &s->loop.max_chi2,
               "graph cost increase above which a loop closure is dropped");
  t.add_double("loop_sigma_xy", &s->loop.sigma_xy,
               "pose graph: standard deviation of a loop-closure edge, metres");
  t.add_double("loop_sigma_theta", &s->loop.sigma_theta_deg, "... degrees");
  t.add_switch("recovery", &s->recovery.enabled,
               "a weak match or a large predicted motion triggers a wide correlative search "
               "(coarse to fine, the ES to finish), and a scan that still agrees poorly is not "
               "written into the map");
  t.add_double("recovery_window_xy", &s->recovery.window_xy, "recovery search window +-, metres");
  t.add_double("recovery_window_theta", &s->recovery.window_theta_deg,
               "recovery search window +-, degrees");
  t.add_double("recovery_weak_agreement", &s->recovery.weak_agreement,
               "a match is weak below this share of end points on occupied cells (of those on "
               "known cells)");
  t.add_double("recovery_lost_view_known", &s->recovery.lost_view_known,
               "a tracked pose with fewer than this share of its end points on observed cells "
               "is weak too (a missed turn looks into unknown space; 0 = never)");
  t.add_double("recovery_min_gain", &s->recovery.min_gain,
               "a weak tracked pose gives way to the recovered one when its consistency with "
               "the map is higher by this plus recovery_gain_per_window times the jump relative to "
               "the search window");
  t.add_double("recovery_gain_per_window", &s->recovery.gain_per_window,
               "... see recovery_min_gain");
  t.add_double("recovery_min_gain_fair", &s->recovery.min_gain_fair,
               "as recovery_min_gain for a tracked pose that was not weak (searched because of "
               "a large motion)");
  t.add_double("recovery_gain_per_window_fair", &s->recovery.gain_per_window_fair,
               "... see recovery_min_gain_fair");
  t.add_double("recovery_fair_short_jump", &s->recovery.fair_short_jump,
               "... but a jump of at most this share of the motion predicted since the last "
               "scan needs only recovery_min_gain's gain (0 = the fair gains for every jump)");
  t.add_switch("recovery_fair_recent_pace", &s->recovery.fair_recent_pace,
               "laser only: ... or of the longest of the last 5 steps, if longer (after a turn "
               "in place the robot drives off at its pace while the prediction stands still)");
  t.add_switch("recovery_through_jump", &s->recovery.through_jump,
               "laser only, after a recovery jump: also search around constant velocity through "
               "the jump (the jump may have been the robot's own motion) when it lies outside the "
               "window, keeping the more consistent result");
  t.add_double("recovery_clear_gain", &s->recovery.clear_gain,
               "a recovered pose at least this much more consistent than the tracked one "
               "replaces it however far the jump (0 = no cap)");
  t.add_double("recovery_min_hits", &s->recovery.min_hits,
               "a recovered pose with under 30 % of its end points on observed cells is still "
               "taken with at least this share of them on hits, and recovery_min_hits_ratio times "
               "the tracked pose's (a missed turn in place into new space; 0 = never)");
  t.add_double("recovery_min_hits_ratio", &s->recovery.min_hits_ratio, "... see recovery_min_hits");
  t.add_int("recovery_tolerance", &s->recovery.tolerance,
            "judging a recovered pose, an end point within this many cells of a cell with hits "
            "counts as on it (beams grazing a wall clear the cells along its face; 0 = its own "
            "cell only)");
  t.add_double("recovery_window_min_scale", &s->recovery.window_min_scale,
               "the recovery window shrinks with the largest of the last 5 inter-scan motions "
               "(1 m or 45 degrees = the whole window), to at least this share of it");
  t.add_double("recovery_weak_min_scale", &s->recovery.weak_min_scale,
               "a weak match triggers the recovery search only when the recent motion is at "
               "least this share of 1 m or 45 degrees per scan");
  t.add_double("recovery_odometry_window_xy", &s->recovery.odometry_window_xy,
               "with odometry, the recovery search is centred on the odometry's pose and its "
               "window is at most this plus recovery_odometry_window_frac times the step's "
               "length, metres (0 = the window as without odometry)");
  t.add_double("recovery_odometry_window_theta", &s->recovery.odometry_window_theta_deg,
               "... and at most this plus recovery_odometry_window_frac times the step's turn, "
               "degrees");
  t.add_double("recovery_odometry_window_frac", &s->recovery.odometry_window_frac,
               "... see recovery_odometry_window_xy");
  t.add_double("recovery_wide_motion_xy", &s->recovery.wide_motion_xy,
               "the recovery search also runs when the predicted motion is this long, metres "
               "(0 = never)");
  t.add_double("recovery_wide_motion_theta", &s->recovery.wide_motion_theta_deg,
               "... or turns this much, degrees (0 = never)");
  t.add_double("recovery_max_speed", &s->recovery.max_speed,
               "laser only: the recovery search also runs when the time since the last scan "
               "would let the robot drive recovery_wide_motion_xy at this speed, with a window "
               "at least that reach (a robot that stood may have driven off), m/s (0 = never)");
  t.add_double("recovery_settled_agreement", &s->recovery.settled_agreement,
               "a large motion does not start the recovery search when the tracked pose "
               "agrees at least this much with the map (0 = it always does) ...");
  t.add_double("recovery_settled_known", &s->recovery.settled_known,
               "... with at least this share of its end points on observed cells");
  t.add_int("recovery_candidates", &s->recovery.candidates,
            "distinct poses of the recovery search's coarse stage refined at full resolution");
  t.add_int("recovery_more_candidates", &s->recovery.more_candidates,
            "... and when none of those fits the map (consistency below recovery_more_below), "
            "the next ones up to this many in all, taken only if one fits");
  t.add_double("recovery_more_below", &s->recovery.more_below,
               "... see recovery_more_candidates (consistency: evidence - contradiction - "
               "see-through, in [-2, 1]; -2 = never)");
  t.add_double("recovery_insert_min_agreement", &s->recovery.insert_min_agreement,
               "a scan agreeing less than this with the map is not written into it (0 = off)");
  t.add_double("key_sigma_xy", &s->key_sigma_xy,
               "pose-graph edge between consecutive inserted scans, metres");
  t.add_double("key_sigma_theta", &s->key_sigma_theta_deg, "... degrees");
  // Reader.
  t.add_enum<EvenBeamConvention>(
      "even_beams", &r->even_beams,
      {{"start", EvenBeamConvention::kStartAtMinus90}, {"centered", EvenBeamConvention::kCentered}},
      "beam angles of FLASER scans with an even beam count: first beam at -90 deg, or centred "
      "(no beam at 0 deg)");
  t.add_float("no_return_range", &r->no_return_range,
              "readings at or above this are no-returns, metres (the value a log writes for "
              "'no echo': 81.9 in the bundled logs, 81.83 or 50 in others; ROBOTLASER1 lines "
              "also use their own maximum_range)");
}

bool is_tracking_param(const std::string& name) {
  static const std::set<std::string> kTracking = {"mu",
                                                  "iterations",
                                                  "alpha_xy",
                                                  "alpha_theta",
                                                  "beta",
                                                  "penalty",
                                                  "odometry",
                                                  "prediction",
                                                  "min_range",
                                                  "max_range",
                                                  "init_sigma_xy",
                                                  "init_sigma_theta",
                                                  "seed",
                                                  "motion_hypotheses",
                                                  "turn_hypotheses",
                                                  "interpolation",
                                                  "search_point_spacing",
                                                  "refine",
                                                  "prior_sigma_xy",
                                                  "prior_sigma_theta",
                                                  "prior_on_stop",
                                                  "motion_hold",
                                                  "motion_hold_ratio",
                                                  "no_return_range"};
  return kTracking.count(name) != 0;
}

}  // namespace esfleet::app
