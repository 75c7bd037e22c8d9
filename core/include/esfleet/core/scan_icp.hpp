#pragma once
// Point-to-line ICP between two scans (ours, beyond the paper): the pose of one scan in the
// frame of another, refined from a starting guess. The final pass of the SLAM uses it to sharpen
// the graph edges between consecutive inserted scans: matched to each other directly, two scans
// a few centimetres apart align more precisely than each does against the 5 cm grid.
//
// Each end point of the moving scan is paired with the nearest end point of the reference scan
// (within max_distance) that has a line through it (its neighbours along the reference scan lie
// on a line); the error is the distance to that line. Gauss-Newton with a Huber kernel, plus a
// weak prior on the start: along a corridor the lines do not constrain the position and the
// start (the tracked motion) stays.
//
// Where they constrain it only a little (a corridor with a door frame or two), the prior does not
// hold it: a few end points paired with the wrong short line pull the result along the corridor.
// So the translation is split by how well the pairs constrain it (the eigenvectors of their
// 2x2 information at the result): along a direction whose information is below
// `degenerate_ratio` times the other's, the start is kept (the solution remapping of Zhang,
// Kaess and Singh, ICRA 2016). Measured in docs/slam.md (item 6).

#include <cstddef>
#include <optional>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet {

struct IcpConfig {
  double max_distance = 0.2;   ///< pairs farther apart than this are not used, metres
  double line_radius = 0.15;   ///< a reference point's line is fitted to its neighbours within this
  double max_line_rms = 0.01;  ///< ... and only if they lie within this of it (RMS), metres
  double huber = 0.03;         ///< Huber threshold on the point-to-line distance, metres
  double point_sigma = 0.02;   ///< standard deviation of a point-to-line distance, metres
  double prior_sigma_xy = 0.1;         ///< weak prior on the start, metres
  double prior_sigma_theta_deg = 3.0;  ///< ... degrees
  int max_iterations = 30;
  double min_pair_share = 0.5;  ///< share of the moving points that must find a line
  std::size_t min_pairs = 30;
  double max_move_xy = 0.1;         ///< a result farther from the start than this is rejected
  double max_move_theta_deg = 2.0;  ///< ... or turned more
  /// A translation direction constrained less than this share of the best-constrained one keeps
  /// the start. 0 = off.
  double degenerate_ratio = 0.1;
  /// A moving end point pairs only with a reference line whose normal is within acos(this) of
  /// its own line's (fitted the same way; a point without one is not paired): a point on one
  /// wall paired with the line of another, e.g. at a corner, pulled real alignments shorter.
  /// 0 = off (every moving point may pair).
  double min_normal_cos = 0.94;

  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

struct IcpResult {
  Pose2 relative;     ///< pose of the moving scan in the reference scan's frame
  std::size_t pairs;  ///< end points paired with a line at the result
  double rms = 0.0;   ///< RMS point-to-line distance of the pairs, metres
  int iterations = 0;
  bool held_along = false;  ///< one direction was degenerate and kept the start's translation
};

/// The pose of `moving` in the frame of `reference`, refined from `start` (both scans in their
/// own sensor frames, end points in beam order). nullopt when too few points pair up, or the
/// result moved more than the config allows from `start`.
std::optional<IcpResult> align_scans(const ScanPoints& reference, const ScanPoints& moving,
                                     const Pose2& start, const IcpConfig& config = {});

}  // namespace esfleet
