#pragma once
// The relations accuracy metric of Kümmerle et al., "On measuring the accuracy of SLAM
// algorithms", Autonomous Robots 27(4), 2009.
//
// A relation is a ground-truth relative pose between two moments of a run, measured by hand-
// checked scan alignment. The metric compares each one with the same relative pose taken from
// the estimated trajectory, so it does not depend on the (arbitrary) global frame of the
// estimate and weighs local and global errors by how the relations were chosen.

#include <cstddef>
#include <optional>
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

/// The two scans a relation's ends fall on: indices into the stamps given to
/// match_relation_ends.
struct RelationEnds {
  std::size_t first = 0;   ///< scan of t1
  std::size_t second = 0;  ///< scan of t2
};

/// For each relation, the scans its ends match as evaluate_relations matches them: the stamp
/// nearest to t - time_offset (a tie goes to the earlier scan), if within the tolerance;
/// std::nullopt when either end matches none. `stamps` need not be sorted; indices refer to it.
/// Matching against a whole log and then keeping the relations whose both ends are kept scans
/// scores a subsampled run honestly: an end whose scan was dropped is not moved to a neighbour.
/// Throws std::invalid_argument as evaluate_relations does (options, non-finite stamp).
std::vector<std::optional<RelationEnds>> match_relation_ends(const std::vector<double>& stamps,
                                                             const std::vector<Relation>& relations,
                                                             const RelationsOptions& options = {});

/// Relations derived from a reference path (e.g. GMapping-corrected poses) instead of hand-made
/// ones: for every gap g and every i with i + g < n, rel = reference[i+g] seen from
/// reference[i], est = estimate[i+g] seen from estimate[i], err = inv(rel)·est; translation
/// error hypot(err.x, err.y) (m), rotation error |err.theta| (deg), as in evaluate_relations.
struct DerivedGap {
  std::size_t gap = 0;
  std::size_t count = 0;    ///< relations of this gap: max(0, n - gap)
  double trans_mean = 0;    ///< metres (0 when count = 0)
  double rot_mean_deg = 0;  ///< degrees
};

struct DerivedRelationsResult {
  std::size_t count = 0;                     ///< relations of all gaps together
  double trans_mean = 0, trans_std = 0;      ///< metres, over all gaps together
  double rot_mean_deg = 0, rot_std_deg = 0;  ///< degrees
  double trans_max = 0;                      ///< metres
  std::vector<DerivedGap> gaps;              ///< one per gap asked for, in the order given
};

/// Scores `estimate` against relations derived from `reference` (both one pose per scan, the
/// same scans in the same order) for each gap in `gaps` (in scans). Means and population
/// standard deviations over the relations; zeros where there are none. Throws
/// std::invalid_argument if the sizes differ, a gap is 0, or a pose is not finite.
DerivedRelationsResult evaluate_derived_relations(const std::vector<Pose2>& reference,
                                                  const std::vector<Pose2>& estimate,
                                                  const std::vector<std::size_t>& gaps);

/// Stamps not after the stamp before them, in the order given: a log whose stamps were printed
/// rounded (the CSAIL key-scan log's have 6 significant digits, so all 406 share one stamp).
/// Matching poses by time (evaluate_relations, evaluate_absolute) is then meaningless, and a
/// SLAM predicting by time takes one step per scan.
struct StampOrder {
  std::size_t not_after = 0;  ///< stamps at or before the stamp before them
  std::size_t first = 0;      ///< index of the first such stamp (when not_after > 0)
};
StampOrder stamp_order(const std::vector<double>& stamps);

/// The absolute trajectory error against reference poses (e.g. a corrected log's): how far the
/// estimate's map is bent or scaled as a whole, which relations between nearby moments hardly
/// see. The estimate is first moved onto the reference by the rotation and translation that
/// minimise the squared position errors (closed form; the estimate's frame is arbitrary).
struct AbsoluteErrorResult {
  std::size_t matched = 0;  ///< reference poses with a trajectory pose within the tolerance
  std::size_t total = 0;    ///< reference poses given
  double rms = 0, mean = 0, max = 0;  ///< position errors after the alignment, metres
  /// The least-squares scale of the estimate onto the reference (> 1: the estimate is smaller
  /// than the reference), and the RMS error after aligning with it as well.
  double scale = 1.0;
  double rms_scaled = 0;
};

/// Scores `trajectory` against `reference`, whose stamps are in the trajectory's time base (a
/// corrected log of the same run): each reference pose against the trajectory pose nearest in
/// time, within `tolerance` seconds (a tie goes to the earlier pose). Fewer than two matches
/// give zero statistics; the caller decides. Throws std::invalid_argument if the tolerance is
/// negative or not finite, or a stamp or reference pose is not finite.
AbsoluteErrorResult evaluate_absolute(const std::vector<TimedPose>& trajectory,
                                      const std::vector<TimedPose>& reference,
                                      double tolerance = 0.15);

}  // namespace esfleet
