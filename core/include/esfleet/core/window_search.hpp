#pragma once
// The best pose in a regular window of candidate poses, scored by HeadingScorer (one pyramid
// level, no interpolation), found by branch and bound instead of scoring every candidate.
//
// Candidates: headings centre.theta + it * step_theta (it in [-n_theta, n_theta]) and positions
// centre + (ix, iy) * step_xy (ix, iy in [-n_xy, n_xy]); their index in the brute-force loop order
// (heading, then y, then x) is ((it + n_theta) * side + iy + n_xy) * side + ix + n_xy with
// side = 2 n_xy + 1.
//
// Exact: the result is the brute-force result bit for bit: the first candidate (lowest index)
// of the highest score, and the highest score of the candidates farther than rival_distance
// from it. A block of 2^h x 2^h positions at one heading is bounded by the sum over the end
// points of the largest (non-negative) cell value any of its positions can put the end point
// on; the penalty factor p_occ is at most 1. The bound's cells come from max-pooled copies of
// the level, one per block size (as Cartographer's precomputation grids, Hess et al. 2016).
//
// A caller that only asks whether the rival is within a ratio of the best (a loop closure's
// ambiguity test) gives that ratio: the rival's search then skips every block whose bound is
// within it and stops at the first candidate beyond it. The rival reported is then exact only
// in what it decides: rival / score exceeds the ratio exactly when the brute-force rival's does.

#include <cstddef>
#include <limits>
#include <optional>

#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet {

struct SearchWindow {
  Pose2 centre;
  double step_xy = 0.1;     ///< metres
  double step_theta = 0.0;  ///< radians
  int n_xy = 0;             ///< positions -n_xy .. n_xy steps in x and in y
  int n_theta = 0;          ///< headings -n_theta .. n_theta steps
};

struct WindowMatch {
  float score = 0.0f;     ///< the best candidate's fitness (> 0)
  std::size_t index = 0;  ///< its index in the brute-force order
  Pose2 pose;             ///< its pose
  /// Best score farther than rival_distance (metres, xy) from it; 0 if none. With a finite
  /// rival_ratio: a score of the candidates that far, the best one when that is within the
  /// ratio (rival / score <= rival_ratio), else one beyond the ratio.
  float rival = 0.0f;
  std::size_t scored = 0;   ///< candidates scored exactly (leaves)
  std::size_t bounded = 0;  ///< blocks bounded
};

/// The candidate pose of `index` (the brute-force loop's formula).
Pose2 window_pose(const SearchWindow& w, std::size_t index);

/// The window's best candidate and its rival (see above); nullopt if no candidate scores > 0.
/// options.interpolate must be false (HeadingScorer). rival_ratio: see WindowMatch::rival
/// (infinity: the rival exactly).
std::optional<WindowMatch> search_window(
    const GridMap& map, const ScanPoints& points, const FitnessOptions& options,
    const SearchWindow& w, double rival_distance,
    double rival_ratio = std::numeric_limits<double>::infinity());

}  // namespace esfleet
