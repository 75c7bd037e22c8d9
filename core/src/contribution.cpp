#include "esfleet/core/contribution.hpp"

#include <cmath>
#include <stdexcept>

#include "esfleet/core/grid_traversal.hpp"

namespace esfleet {

void ContributionConfig::validate() const {
  auto check = [](bool ok, const char* what) {
    if (!ok) throw std::invalid_argument(what);
  };
  check(min_known >= 0.0 && min_known <= 1.0, "contribution.min_known must be in [0, 1]");
  check(min_agreement >= 0.0 && min_agreement <= 1.0,
        "contribution.min_agreement must be in [0, 1]");
  check(max_refine_xy > 0.0 && max_refine_theta_deg > 0.0,
        "contribution.max_refine_xy and max_refine_theta must be > 0");
  check(contradiction_min_hits >= 1, "contribution.contradiction_min_hits must be >= 1");
  check(contradiction_margin >= 0.0, "contribution.contradiction_margin must be >= 0");
  check(max_contradiction >= 0.0 && max_contradiction <= 1.0,
        "contribution.max_contradiction must be in [0, 1]");
  check(min_beams >= 1, "contribution.min_beams must be >= 1");
  check(chain_sigma_xy > 0.0 && chain_sigma_theta_deg > 0.0 && anchor_sigma_xy > 0.0 &&
            anchor_sigma_theta_deg > 0.0,
        "contribution sigmas must be > 0");
  check(redundant_xy >= 0.0 && redundant_theta_deg >= 0.0,
        "contribution.redundant_xy and redundant_theta must be >= 0");
  check(chain_max_gap >= 0.0 && anchor_radius >= 0.0 && loop_chain_travel >= 0.0,
        "contribution.chain_max_gap, anchor_radius and loop_chain_travel must be >= 0");
}

void ContributorConfig::validate() const {
  if (!(min_agreement >= 0.0 && min_agreement <= 1.0)) {
    throw std::invalid_argument("contribute.min_agreement must be in [0, 1]");
  }
  if (!(min_known >= 0.0 && min_known <= 1.0)) {
    throw std::invalid_argument("contribute.min_known must be in [0, 1]");
  }
  if (!(min_travel >= 0.0) || !(min_turn_deg >= 0.0)) {
    throw std::invalid_argument("contribute.min_travel and min_turn must be >= 0");
  }
}

bool worth_contributing(const ContributorConfig& config, const FitnessValue& value,
                        const Pose2& pose, const std::optional<Pose2>& last_sent) {
  if (value.agreement() < config.min_agreement || value.known_share() < config.min_known) {
    return false;
  }
  if (!last_sent) return true;
  const Pose2 d = pose.relative_to(*last_sent);
  return std::hypot(d.x, d.y) >= config.min_travel ||
         std::abs(normalize_angle(d.theta)) >= deg_to_rad(config.min_turn_deg);
}

const char* to_string(ContributionVerdict v) {
  switch (v) {
    case ContributionVerdict::kAccepted:
      return "accepted";
    case ContributionVerdict::kTooFewBeams:
      return "too_few_beams";
    case ContributionVerdict::kUnknownPlace:
      return "unknown_place";
    case ContributionVerdict::kDisagrees:
      return "disagrees";
    case ContributionVerdict::kRefineMoved:
      return "refine_moved";
    case ContributionVerdict::kContradicts:
      return "contradicts";
    case ContributionVerdict::kRedundant:
      return "redundant";
  }
  return "unknown";
}

float occupied_contradiction(const GridMap& map, const ScanPoints& points, const Pose2& pose,
                             int min_hits, double margin) {
  if (points.size() == 0) return 0.0f;
  const double inv = 1.0 / map.cell_size();
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  const double sx = pose.x * inv, sy = pose.y * inv;
  const auto min_hit = static_cast<std::uint32_t>(min_hits);
  std::size_t through = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    // The beam up to `margin` before its end point: a wall seen a few cells short of where the
    // map has it is noise, not a contradiction.
    const double r = points.range[i];
    if (r <= margin) continue;
    const double f = (r - margin) / r;
    const double ex = sx + f * (c * points.x[i] - s * points.y[i]) * inv;
    const double ey = sy + f * (s * points.x[i] + c * points.y[i]) * inv;
    bool crossed = false;
    traverse(sx, sy, ex, ey, [&](CellIndex cell) {
      if (crossed) return;
      const std::uint32_t hit = map.hit(cell);
      if (hit >= min_hit && hit >= 2 * map.err(cell)) crossed = true;
    });
    if (crossed) ++through;
  }
  return static_cast<float>(static_cast<double>(through) / static_cast<double>(points.size()));
}

}  // namespace esfleet
