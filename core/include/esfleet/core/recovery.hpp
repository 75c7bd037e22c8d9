#pragma once
// Recovery from a weak match (ours, beyond the paper): when the pose the tracking step found
// for a scan agrees poorly with the map (the robot moved or turned far more than predicted:
// dropped scans, key-scan logs, fast robots), a correlative search over a wide window around
// the prediction finds where the scan fits, coarse to fine, and the (mu+1)-ES finishes from
// the best candidates:
//   1. coarse: the map around the prediction is max-pooled into cells 2^coarse_level larger;
//      every pose of a grid (+-window_xy in steps of half a coarse cell, +-window_theta in
//      steps that move an end point at the median range by about one coarse cell) is scored
//      by the sum of the pooled values at up to `points` end points: an occupied cell its map
//      value, a free one -free_penalty, an unknown one 0 (the maximum over the block: a true
//      pose never scores low);
//   2. fine: the `candidates` best distinct coarse poses (more when none fits: see
//      more_candidates) are searched again at full resolution
//      in a neighbourhood of one coarse step;
//   3. the ES (the tracking's own configuration) starts from a population holding those
//      candidates and polishes the best, on the full scan.
// The result is taken only when it agrees clearly better with the map than the tracked pose
// (Slam decides; see SlamConfig::recovery).

#include <cstdint>
#include <vector>

#include "esfleet/core/es_search.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/core/scan_points.hpp"
#include "esfleet/core/tracking.hpp"

namespace esfleet {

struct RecoveryConfig {
  /// On by default: key-scan logs, dropped scans and fast robots need it; on the dense
  /// benchmark logs it rarely runs (docs/slam.md item 7). SlamConfig::paper() turns it off.
  bool enabled = true;
  /// A tracked pose is weak when, with at least `min_known` of its end points on observed
  /// cells, fewer than `weak_agreement` of those fall on cells with hits.
  double weak_agreement = 0.7;
  double min_known = 0.3;
  /// A tracked pose is also weak when fewer than this share of its end points fall on observed
  /// cells: a turn the prediction missed leaves the scan looking into unknown space (fr079 every
  /// 8th scan: a 35 deg turn tracked as -5 deg put 11 % of the end points on known cells, the
  /// true pose 96 %). 0 = never.
  double lost_view_known = 0.2;
  /// The search also runs, whatever the match, when the motion since the last scan is
  /// predicted to be at least this large (key-scan logs, dropped scans): a local search can
  /// settle on a wrong pose that agrees well with the little the map knows ahead. 0 = never.
  double wide_motion_xy = 0.4;          ///< metres
  double wide_motion_theta_deg = 15.0;  ///< degrees
  /// ... or when the time since the last scan would let the robot travel wide_motion_xy at this
  /// speed, whatever the predicted motion: a robot that stood still may have driven off (fr079
  /// every 8th scan: 0.9 m in one 2 s step after standing, tracked as 0.06 m with agreement
  /// 0.70, docs/slam.md item 7). The window is then at least that reach. A stamp not after the
  /// last scan's (the rounded stamps of a key-scan log) gives no time; with odometry the motion
  /// is measured and this plays no part. 0 = never.
  double max_speed = 1.0;  ///< metres per second
  /// ... unless the tracked pose has settled: at least `settled_agreement` of its end points on
  /// observed cells fall on cells with hits, and at least `settled_known` of them are on
  /// observed cells (an in-place turn in a mapped room). Of the searches a large motion alone
  /// started, none that this skips replaced a pose on the sparse logs, and it skips most of
  /// those on the dense ones (docs/slam.md). settled_agreement 0 = never skip.
  double settled_agreement = 0.93;
  double settled_known = 0.9;
  double window_xy = 1.5;          ///< search +- this around the prediction, metres
  double window_theta_deg = 90.0;  ///< ... and +- this, degrees
  /// Slam: the window is scaled by the last inter-scan motion, step / window_scale_xy +
  /// turn / window_scale_theta, clamped to [window_min_scale, 1].
  double window_scale_xy = 1.0;          ///< metres
  double window_scale_theta_deg = 45.0;  ///< degrees
  double window_min_scale = 0.25;
  /// Slam: a weak match triggers the search only when that scale is at least this (0.5: the
  /// robot moves about half a metre or 22 degrees per scan); a large predicted motion always
  /// does. 0 = any weak match.
  double weak_min_scale = 0.0;
  /// Slam, with odometry: the search is centred on the odometry's predicted pose, heading
  /// included, and its window is at most what wheel odometry can be off by over the step:
  /// odometry_window_xy + odometry_window_frac * the step's length, and odometry_window_theta +
  /// odometry_window_frac * its turn. Without the bound a drifted map made a pose turned 88
  /// degrees from the odometry's look better, and the run broke (the key-scan log with an 8 m
  /// laser and noisy odometry, key scan 217, 2 of 10 seeds; docs/slam.md item 7). Generous,
  /// because real odometry lags: CSAIL's raw odometry (every 3rd scan) reports turns up to 45
  /// degrees late or early, and the search must still correct those. odometry_window_xy 0 = the
  /// window as without odometry, centred on the previous heading.
  double odometry_window_xy = 0.5;          ///< metres
  double odometry_window_theta_deg = 20.0;  ///< degrees
  double odometry_window_frac = 0.75;
  int coarse_level = 2;     ///< pooled cells are 2^level map cells
  int points = 120;         ///< end points scored in the coarse and fine stages
  double max_range = 20.0;  ///< end points farther than this are left out of both
  /// What an end point on a known free cell scores in the coarse and fine stages (an occupied
  /// cell scores its map value, an unknown one 0).
  double free_penalty = 0.5;
  int candidates = 8;  ///< distinct coarse poses refined
  /// ... and when none of them fits the map (consistency under `more_below`), the next distinct
  /// coarse poses up to `more_candidates` in all; the best of those is taken only if it fits.
  /// The max-pooled coarse stage can rank poses that put end points near any wall above a true
  /// pose that sees mostly new space: on the key-scan log (key scan 370, seeds 1, 4 and 20) the
  /// true pose was the 19th, 16th and 25th distinct coarse pose (consistency 0.41), none of the
  /// first 8 scored above -0.15, and the run broke. Refining 24 in every search broke CSAIL
  /// every 5th scan instead (a wrong candidate more consistent than the true one), and so did
  /// taking a poorly fitting one of the extra candidates (docs/slam.md item 7). With a 1 deg
  /// laser (every other beam) the true pose at key scan 370 was the 33rd (seed 7): 64, not 32.
  int more_candidates = 64;
  double more_below = 0.2;
  double distinct_xy = 0.3;  ///< coarse poses closer than this (and distinct_theta) are one
  double distinct_theta_deg = 5.0;
  /// Slam: the recovered pose replaces the tracked one when its consistency score (below) is
  /// higher by min_gain + gain_per_window * d, d the jump between the two poses relative to the
  /// (scaled) window: xy / window_xy + turn / window_theta. The farther the jump, the clearer
  /// the evidence must be (a corridor fits about as well a metre back, where the scan sees less
  /// unknown space). For a weak tracked pose; a fair one, searched because of the motion, needs
  /// the *_fair ones.
  double min_gain = 0.05;
  double gain_per_window = 0.15;
  double min_gain_fair = 0.15;
  double gain_per_window_fair = 0.375;
  /// ... yet a fair tracked pose needs only the weak one's gain for a jump no longer than this
  /// share of the motion predicted since the last scan (xy): a fair match can be off by up to
  /// the motion it was predicted across, while a jump longer than the motion is the case the
  /// *_fair gains guard against. On sparse logs (a metre per scan) the tracking settles on
  /// fair-looking poses 0.2-0.5 m off (key-scan log, key scan 200: 0.39 m sideways, the
  /// recovered pose 0.098 more consistent, 0.24 needed); on a dense log a 0.36 m jump after a
  /// 0.23 m step was wrong (CSAIL scan 1006). 0 = the *_fair gains for every jump
  /// (docs/slam.md item 7).
  double fair_short_jump = 1.0;
  /// Laser only, the motion a fair jump is measured against is at least the longest of the
  /// last 5 steps: after a turn in place the prediction has the robot standing while it drives
  /// off at its pace. Simulated, in fr079's corridor at 1 m per scan, the tracking then settled
  /// 0.7 m behind (the map's fitness higher there than at the true pose), and the recovered
  /// pose, right and 0.26 more consistent, was refused against 0.33 needed; that run, a 1.5 m/s
  /// one and a noisy laser's broke (0.49, 0.83 and 0.27 m; docs/benchmarks.md, "A second
  /// simulated building"). With odometry the motion is measured and this is not used.
  bool fair_recent_pace = true;
  /// Laser only, after a recovery jump: the prediction continues the step before the jump (the
  /// jump taken as a correction of the estimate), but the jump may have been the robot's own
  /// motion. Then constant velocity through the jump is searched too, with the same window,
  /// when it lies outside the window, and the more consistent of the two results is kept. On
  /// fr079 every 10th scan with a 1 deg laser the robot reverses at scan 138 (0.8 m, then 1.2 m
  /// at 139): the jump at 138 was that reversal, the prediction at 139 drove on forwards, 2 m
  /// from the truth, outside the window, and 7 of 20 seeds broke (docs/slam.md item 7).
  bool through_jump = true;
  /// ... but a gain of at least this is taken however far the jump: a corridor's slide gains
  /// little, a pose this much more consistent is not a near miss (fr079 every 8th scan, 1 deg
  /// laser: a tracked pose turned by 100 deg with agreement 0.79, the right one 0.72 more
  /// consistent, refused against 0.83 needed; docs/slam.md item 7). A weak tracked pose needs
  /// less (0.35 at the window's edge). 0 = no cap.
  double clear_gain = 0.5;
  /// A recovered pose needs min_known of its end points on observed cells, unless at least
  /// this share of them fall on cells with hits and at least min_hits_ratio times as many as at
  /// the tracked pose: a turn in place the prediction missed shows mostly new space while the map
  /// holds one or a few scans (a simulated robot at 1 scan/s turning 60 deg before it drives: the
  /// true pose 21 % known, 92 % of those hits, the tracked pose none; docs/slam.md item 7).
  /// 0 = never.
  double min_hits = 0.1;
  /// (The key-scan log, key scan 370, seed 1: the true pose 30 % known, 92 % of those hits,
  /// 1.93 times the tracked pose's hits, was refused at 2.)
  double min_hits_ratio = 1.5;
  /// Consistency: an end point within this many cells of a cell with hits counts as evidence,
  /// not as a contradiction (0 = its own cell only). Beams that graze a wall clear the cells
  /// along its face, so a true pose along a corridor seen from afar puts many end points on
  /// free cells next to the wall's hits and loses to a pose slid back along it, whose end
  /// points land where the wall was seen head-on (key-scan log, key scan 155; docs/slam.md
  /// item 7).
  int tolerance = 1;
  /// Slam: a scan whose final agreement stays below this (with min_known observed) is not
  /// written into the map. 0 = every scan the insertion rule picks is written.
  double insert_min_agreement = 0.5;
  /// Throws std::invalid_argument naming the field (as "slam.recovery_<field>").
  void validate() const;
};

/// How consistent a scan at a pose is with the map, over all its end points: the share on
/// cells with hits or within `tolerance` cells of one (evidence), minus the share on known
/// free cells with no hit that near (contradiction), minus the
/// share of beams that pass through a cell seen occupied more often than free before their end
/// (see-through: a wrong pose in a symmetric place looks through walls). In [-2, 1].
struct Consistency {
  float evidence = 0.0f;
  float contradiction = 0.0f;
  float see_through = 0.0f;
  float score() const { return evidence - contradiction - see_through; }
};
/// All zero for a pose beyond any map (beyond_any_map).
Consistency consistency(const GridMap& map, const ScanPoints& points, const Pose2& pose,
                        int tolerance);

/// True when `v` is a weak match by `config` (see RecoveryConfig::weak_agreement).
bool weak_match(const RecoveryConfig& config, const FitnessValue& v);

/// The consistency gain a recovered pose needs over the tracked one to replace it, for a jump
/// `d` relative to the search window (xy / window_xy + turn / window_theta): min_gain +
/// gain_per_window * d for a weak tracked pose, the *_fair ones for a fair one, at most
/// clear_gain (when > 0).
double gain_needed(const RecoveryConfig& config, bool weak, double d);

/// Whether a recovered pose `jump_xy` metres from the tracked one is held to the weak gains:
/// the tracked pose is weak, or the jump is at most config.fair_short_jump times `moved`, the
/// motion predicted since the last scan (metres).
bool judged_as_weak(const RecoveryConfig& config, bool weak, double jump_xy, double moved);

/// Whether a recovered pose's view overlaps the map enough to replace the tracked one:
/// config.min_known of its end points on observed cells, or config.min_hits of them on cells
/// with hits and at least twice as many as `tracked` has.
bool overlaps_enough(const RecoveryConfig& config, const FitnessValue& recovered,
                     const FitnessValue& tracked);

struct RecoveryResult {
  EsResult result;                ///< the pose found and its fitness terms (tracking's fitness)
  std::vector<Pose2> coarse;      ///< the distinct coarse candidates, best first (diagnostics)
  std::int64_t coarse_poses = 0;  ///< poses scored in the coarse stage
};

/// The correlative search around `centre` (Slam: the predicted position with the previous
/// heading, as a turn is what a prediction gets most wrong), finished by `es` with
/// `tracking`'s fitness. Draws
/// from `rng`. Returns nothing useful (coarse empty, result.value all zero) when the map has
/// nothing known in the window, or the centre lies beyond any map (beyond_any_map).
RecoveryResult recover_pose(const RecoveryConfig& config, const TrackingConfig& tracking,
                            const EvolutionStrategy& es, Rng& rng, const GridMap& map,
                            const ScanPoints& points, const Pose2& centre);

}  // namespace esfleet
