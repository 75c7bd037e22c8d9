#include "esfleet/core/evidence.hpp"

#include <cmath>

namespace esfleet {

float evidence(const FitnessValue& v) {
  return v.n_points > 0 ? static_cast<float>(v.n_hit) / static_cast<float>(v.n_points) : 0.0f;
}

float contradiction(const FitnessValue& v) {
  return v.n_points > 0 ? static_cast<float>(v.n_known - v.n_hit) / static_cast<float>(v.n_points)
                        : 0.0f;
}

EvidencePose best_evidence_near(const FitnessEvaluator& eval, const Pose2& centre, double half_xy,
                                double step_xy, int half_turn_deg) {
  EvidencePose best{centre, -1.0f};
  const int n = static_cast<int>(std::lround(half_xy / step_xy));
  for (int it = -half_turn_deg; it <= half_turn_deg; ++it) {
    for (int iy = -n; iy <= n; ++iy) {
      for (int ix = -n; ix <= n; ++ix) {
        const Pose2 p{centre.x + ix * step_xy, centre.y + iy * step_xy,
                      normalize_angle(centre.theta + it * deg_to_rad(1.0))};
        const float e = evidence(eval.evaluate(p));
        if (e > best.evidence) best = {p, e};
      }
    }
  }
  return best;
}

}  // namespace esfleet
