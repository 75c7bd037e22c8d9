#pragma once
// Map update (paper Algorithm 1): write one scan into the grid at the pose the search chose.
//
// For every valid beam, each cell the beam crosses before its end point gets err += 1 and the
// end-point cell gets hit += 1. The paper samples L_i = ceil(alpha_res * d_i) points along the
// beam; by default we walk the exact cell sequence instead (Amanatides-Woo traversal: each
// crossed cell once per beam), the limit of that sampling. No-return beams add no hit; they may
// clear cells up to a free-space limit (off by default).
//
// Beyond the paper, a beam's err counting stops free_margin short of its end point (ours,
// default 0.15 m; 0 = the paper). With every crossed cell counted, a beam whose range reads a
// little long clears the cell of the surface it hit, and one that reads short hits the cell in
// front of it, so each surface sits in the map a little towards the side it was seen from. The
// scan matcher then places later scans too far along their way: on CSAIL and fr079 the tracked
// motion was 1.1-1.4 % longer than the reference relations, about 0 % with the margin
// (docs/slam.md, "Accuracy").

#include <cstddef>

#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet {

struct MapUpdateConfig {
  /// true: exact grid traversal (ours, default); false: the paper's L_i = ceil(alpha_res * d_i)
  /// sample points per beam, each sampled cell counted once per beam.
  bool exact_traversal = true;
  double alpha_res = 20.0;  ///< sample points per metre of beam when exact_traversal is false
  /// No-return beams clear cells up to this range (metres); 0 = they change nothing (default).
  /// At most write_range.
  double no_return_clear_range = 0.0;
  /// The map-writing range (metres, in (0, kMaxBeamRange]; like GMapping's usable range
  /// maxUrange, whose default it takes): an end point farther than this is not written, and
  /// its beam clears the cells it crosses up to this range, as a no-return beam clears them
  /// up to no_return_clear_range. The matching still uses it. It bounds what one scan costs:
  /// a scan of 10 000 beams all reading 999 m walked 2.6e8 cells and created tiles up to
  /// 11.2 GB in 74 s (docs/fuzzing.md, "What one scan may cost"); a laser's own no-returns
  /// (81.9 m on CSAIL and fr079) are beyond it, and their readings below it.
  double write_range = 80.0;
  /// A beam counts err only in the cells it crosses more than this before its end point
  /// (metres; 0 = every crossed cell, the paper). The cell a beam ends in always gets its hit.
  double free_margin = 0.15;
  /// Beam fill (ours; SlamConfig::paper(): 0 = off): a laser coarser than beam_fill_deg is
  /// written with end points added between adjacent beams whose ranges differ by at most
  /// beam_fill_max_gap metres (BeamFill, prepare_scan; map_points), so that its walls are as
  /// continuous in the map as a 0.5 deg laser's, the resolution the matching thresholds were
  /// measured with. The matching uses the scan's own beams; key scans keep the filled points
  /// (loop closure re-writes and matches them). A laser at least that fine is unchanged.
  /// docs/slam.md item 11: a key-scan log with a 1 deg laser holds on more seeds with it.
  double beam_fill_deg = 0.5;
  double beam_fill_max_gap = 0.2;
  /// The SLAM fills a scan only while the scans are far apart: this scan's step or one of
  /// the 5 before it moved at least beam_fill_min_step metres or turned at least
  /// beam_fill_min_turn_deg degrees (the first scan counts as far). Scans close together
  /// (0.2 s apart) gained nothing from the fill and lost a little accuracy (docs/slam.md item
  /// 11). Both 0 = every scan. Contributions (Slam::contribute) are always filled.
  double beam_fill_min_step = 0.3;
  double beam_fill_min_turn_deg = 15.0;
  void validate() const;
};

struct MapUpdateStats {
  std::size_t hits = 0;          ///< hit increments
  std::size_t errs = 0;          ///< err increments
  std::size_t out_of_range = 0;  ///< cell writes refused (outside the allowed tile range)
};

/// The end points a scan is written into the map with: prepare_scan with `min_range` and
/// `max_range` (the tracking's) and the config's beam fill. `filled` is false when the fill
/// adds nothing (off, or a laser at least beam_fill_deg fine): then the end points are those
/// the tracking matches, and `points` is left empty.
struct MapPoints {
  bool filled = false;
  ScanPoints points;
  /// The points to write: the filled ones, or `own` (the scan's own end points) if none.
  const ScanPoints& or_own(const ScanPoints& own) const { return filled ? points : own; }
};
MapPoints map_points(const LaserScan& scan, float min_range, float max_range,
                     const MapUpdateConfig& config);

/// Inserts `points` seen from `pose` into `map` and commits the update (tile versions bumped
/// once, touched tiles marked dirty). With `remove`, undoes exactly what the same call without
/// it added (counters are additive), e.g. to move a scan after loop closure; with
/// `commit` false the caller commits (to batch several scans into one map update), and the
/// changed cells keep their old scores until it does (GridMap::add_err_deferred). A pose
/// beyond any map (beyond_any_map), or with a heading that is not finite, writes nothing.
MapUpdateStats update_map(GridMap& map, const ScanPoints& points, const Pose2& pose,
                          const MapUpdateConfig& config = {}, bool remove = false,
                          bool commit = true);

}  // namespace esfleet
