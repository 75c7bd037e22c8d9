#pragma once
// The relations accuracy metric of Kümmerle et al., "On measuring the accuracy of SLAM
// algorithms", Autonomous Robots 27(4), 2009.
//
// A relation is a ground-truth relative pose between two moments of a run, measured by hand-
// checked scan alignment. The metric compares each one with the same relative pose taken from
// the estimated trajectory, so it does not depend on the (arbitrary) global frame of the
// estimate and weighs local and global errors by how the relations were chosen.

#include <cstddef>
#include <string>
#include <vector>

#include "esfleet/core/geometry.hpp"

namespace esfleet {

/// One ground-truth relation: the pose at t2 seen from the pose at t1 (x forward, y left,
/// theta = heading at t2 minus heading at t1).
struct Relation {
  double t1 = 0;
  double t2 = 0;
  Pose2 rel;
};

/// Reads a Kümmerle .relations file: "t1 t2 x y z roll pitch yaw" per line (z, roll, pitch are
/// ignored; yaw is taken as theta and wrapped to (-pi, pi]), in file order. '#' comments and
/// blank lines are skipped. Throws std::runtime_error "<path>:<line>: <what>" on a malformed
/// line (wrong field count, non-numeric, non-finite) and a std::runtime_error naming the path
/// if the file cannot be opened or read.
std::vector<Relation> read_relations(const std::string& path);

struct RelationsOptions {
  double time_offset = 0.0;  ///< relation stamp = trajectory stamp + time_offset (fr079: 1211.45)
  double tolerance = 0.15;   ///< a relation stamp matches the nearest trajectory pose within this
                             ///< many seconds (inclusive)
  /// A relation counts as an outlier (the trajectory broke there) when its error exceeds
  /// either threshold.
  double outlier_trans = 0.5;     ///< metres
  double outlier_rot_deg = 10.0;  ///< degrees
};

struct RelationsResult {
  double trans_mean = 0, trans_std = 0;      ///< metres
  double rot_mean_deg = 0, rot_std_deg = 0;  ///< degrees, of the absolute rotation error
  std::size_t matched = 0;                   ///< relation lines with both stamps matched
  std::size_t total = 0;                     ///< relation lines given
  double trans_max = 0;                      ///< metres, worst matched relation
  std::size_t outliers = 0;                  ///< matched relations beyond the outlier thresholds
};

/// Scores `trajectory` against `relations` (Kümmerle et al. 2009). For each relation:
/// P1, P2 = the trajectory poses nearest in time to t1 - time_offset and t2 - time_offset (a
/// tie goes to the earlier pose); if either is farther than `tolerance` the relation is
/// skipped. Otherwise est = inv(P1)·P2, err = inv(rel)·est, translation error =
/// hypot(err.x, err.y) (m), rotation error = |normalize_angle(err.theta)| (reported in deg).
/// Returns mean and population standard deviation (divide by N) over the matched relations.
/// The trajectory need not be sorted. Nothing matched (including empty inputs) is not an
/// error: the result has matched = 0 and zero statistics; the caller decides.
/// Throws std::invalid_argument if time_offset is not finite, tolerance is negative or not
/// finite, or a trajectory stamp is not finite.
RelationsResult evaluate_relations(const std::vector<TimedPose>& trajectory,
                                   const std::vector<Relation>& relations,
                                   const RelationsOptions& options = {});

}  // namespace esfleet
