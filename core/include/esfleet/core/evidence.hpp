#pragma once
// The localiser's measures of how well a scan explains a pose in a map, besides the paper's
// fitness: evidence (end points on cells seen occupied) and contradiction (end points on known
// free space). Unlike the fitness they count end points in unknown or free space against the
// pose, which tells look-alike places apart.

#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"

namespace esfleet {

/// The share of all end points that fall on cells with hit > 0 (agreement times known share),
/// in [0, 1].
float evidence(const FitnessValue& v);
/// The share of all end points on known cells without hits (known free space), in [0, 1].
float contradiction(const FitnessValue& v);

/// The pose of highest evidence() on a grid around `centre`: positions within +-half_xy in
/// steps of step_xy, headings within +-half_turn_deg in 1-degree steps; among equals the first
/// in scan order (heading, then y, then x). The localiser's check before declaring a pose, and
/// the benchmark's re-alignment of reference poses to a map.
struct EvidencePose {
  Pose2 pose;
  float evidence = -1.0f;
};
EvidencePose best_evidence_near(const FitnessEvaluator& eval, const Pose2& centre, double half_xy,
                                double step_xy, int half_turn_deg);

}  // namespace esfleet
