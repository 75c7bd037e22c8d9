#include "app/slam_params.hpp"

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
  // ES (paper Eq. 9, Table 2).
  t.add_int("mu", &s->es.mu, "ES parents");
  t.add_int("iterations", &s->es.iterations, "ES iterations T per scan (one child each)");
  t.add_double("alpha_xy", &s->es.alpha_xy, "mutation coefficient alpha_1 = alpha_2, cm");
  t.add_double("alpha_theta", &s->es.alpha_theta, "mutation coefficient alpha_3, degrees");
  t.add_double("beta", &s->es.beta, "mutation offset beta (cm for x, y; degrees for theta)");
  t.add_switch("penalty", &s->use_penalty,
               "fitness with the penalty p_occ (paper Condition 1); off = Condition 2");
  // Pipeline.
  t.add_switch("odometry", &s->use_odometry, "predict with the log's odometry increments");
  t.add_choice(
      "prediction", {"previous", "constant-velocity"},
      [s](const std::string& v) {
        s->prediction =
            v == "previous" ? MotionPrediction::kPreviousPose : MotionPrediction::kConstantVelocity;
      },
      [s] {
        return std::string(s->prediction == MotionPrediction::kPreviousPose ? "previous"
                                                                            : "constant-velocity");
      },
      "pose prediction without odometry");
  t.add_float("min_range", &s->min_range, "ignore beams shorter than this, metres");
  t.add_float("max_range", &s->max_range, "ignore beams at or beyond this, metres (0 = all)");
  t.add_double("init_sigma_xy", &s->init_sigma_xy,
               "initial population spread around the prediction, metres");
  t.add_double("init_sigma_theta", &s->init_sigma_theta_deg,
               "initial population spread around the prediction, degrees");
  t.add_u64("seed", &s->seed, "random seed of the ES (same input + seed = same output)");
  // Reader.
  t.add_choice(
      "even_beams", {"start", "centered"},
      [r](const std::string& v) {
        r->even_beams =
            v == "start" ? EvenBeamConvention::kStartAtMinus90 : EvenBeamConvention::kCentered;
      },
      [r] {
        return std::string(r->even_beams == EvenBeamConvention::kStartAtMinus90 ? "start"
                                                                                : "centered");
      },
      "beam angles of FLASER scans with an even beam count: first beam at -90 deg, or centred "
      "(no beam at 0 deg)");
}

}  // namespace esfleet::app
