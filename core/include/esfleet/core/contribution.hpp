#pragma once
// Contributed scans (ours, beyond the paper): a follower that tracks its own pose in the shared
// map sends its scans with that pose, and the leader writes them into the map where it has
// never been itself, after checks of its own (Slam::contribute). A contribution is accepted
// only when
//   1. the scan agrees with the map at the claimed pose (known share and agreement),
//   2. a local refine with the same ES moves it only a little, and
//   3. it does not contradict cells the map has seen occupied many times (beams that pass
//      through them).
// An accepted scan becomes a key scan of the leader's pose graph: tied to the contributor's
// previous accepted scan by its own relative motion and to the nearest key scan of another
// robot by where the refine put it, so a loop closed by any robot corrects the whole map.

#include <cstdint>
#include <optional>
#include <string>

#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet {

struct ContributionConfig {
  /// Check 1: at the claimed pose at least this share of the end points on known cells ...
  double min_known = 0.3;
  /// ... and at least this agreement (FitnessValue::agreement) there and at the refined pose.
  double min_agreement = 0.7;
  /// Check 2: the refine may move the claimed pose at most this far.
  double max_refine_xy = 0.10;        ///< metres
  double max_refine_theta_deg = 2.0;  ///< degrees
  /// Check 3: a cell the map has seen occupied many times has hit >= contradiction_min_hits
  /// and hit >= 2 err; a beam contradicts the map when it passes through such a cell more
  /// than contradiction_margin before its end point. At most max_contradiction of the beams may.
  int contradiction_min_hits = 5;
  double contradiction_margin = 0.25;  ///< metres
  double max_contradiction = 0.05;
  /// Fewer valid beams than this: refused.
  int min_beams = 20;
  /// A scan that passed check 1 within this distance and turn of a key scan already in the
  /// graph adds little and is skipped (kRedundant, neither accepted nor rejected): the key
  /// scans, the graph and the leader's work then grow with the area mapped, not with the time
  /// robots drive through it. 0 = every scan is inserted.
  double redundant_xy = 0.3;          ///< metres
  double redundant_theta_deg = 10.0;  ///< degrees
  /// The contributor's own key scans count only once they are this old (scan stamps): in new
  /// space it extends the map at the key-scan spacing, which it needs to keep tracking.
  double redundant_own_after_s = 60.0;
  /// Graph: the edge to the contributor's previous accepted scan (its own motion, if the two
  /// are at most chain_max_gap apart) and the edge to the nearest key scan of another robot
  /// within anchor_radius (where the refine put it).
  double chain_sigma_xy = 0.02;         ///< metres
  double chain_sigma_theta_deg = 0.5;   ///< degrees
  double chain_max_gap = 2.0;           ///< metres
  double anchor_radius = 4.0;           ///< metres
  double anchor_sigma_xy = 0.05;        ///< metres
  double anchor_sigma_theta_deg = 1.0;  ///< degrees
  /// An anchor edge after this much travel along the contributor's chain without one closes a
  /// loop: the graph is optimised and the map re-written where key scans moved.
  double loop_chain_travel = 10.0;  ///< metres
  /// Throws std::invalid_argument naming the field ("contribution.<field>").
  void validate() const;
};

/// One scan a follower sends with its pose in the shared map.
struct Contribution {
  std::string robot;      ///< the contributor's robot id
  std::uint32_t seq = 0;  ///< the contributor's sequence number of the scan
  LaserScan scan;
  Pose2 pose;  ///< where the contributor says the scan was taken (map frame)
};

enum class ContributionVerdict : std::uint8_t {
  kAccepted = 0,
  kTooFewBeams,   ///< fewer than min_beams valid beams
  kUnknownPlace,  ///< too few end points on known cells at the claimed pose
  kDisagrees,     ///< agreement below min_agreement
  kRefineMoved,   ///< the refine moved the pose too far
  kContradicts,   ///< beams through cells seen occupied many times
  kRedundant,     ///< agrees, but a key scan is already this close: skipped, not a rejection
};
const char* to_string(ContributionVerdict v);

struct ContributionResult {
  ContributionVerdict verdict = ContributionVerdict::kTooFewBeams;
  Pose2 refined;          ///< the pose after the refine (where an accepted scan is written)
  FitnessValue value;     ///< fitness terms at `refined` (at the claimed pose if not refined)
  double moved_xy = 0.0;  ///< refined vs claimed, metres
  double moved_theta_deg = 0.0;  ///< ... degrees
  float contradiction = 0.0f;    ///< share of beams through cells seen occupied many times
  bool loop_closed = false;      ///< the graph was optimised (an anchor after a long chain)
  bool accepted() const { return verdict == ContributionVerdict::kAccepted; }
  /// Refused in a way that says the claimed pose is likely wrong (unknown place, disagrees,
  /// the refine moved it): what makes a follower relocalise after several in a row. A
  /// contradiction may be the world changing (a door opened) or the map being off there.
  bool pose_doubtful() const {
    return verdict == ContributionVerdict::kUnknownPlace ||
           verdict == ContributionVerdict::kDisagrees ||
           verdict == ContributionVerdict::kRefineMoved;
  }
  /// Refused: the scan does not fit the map (kRedundant and kAccepted are not).
  bool rejected() const {
    return verdict != ContributionVerdict::kAccepted && verdict != ContributionVerdict::kRedundant;
  }
};

/// The follower's side: which of its tracked scans it sends (esfleet-follower --contribute).
struct ContributorConfig {
  double min_agreement = 0.8;  ///< the tracked pose's agreement with the map
  double min_known = 0.5;      ///< ... and its share of end points on known cells
  double min_travel = 0.1;     ///< since the last scan sent, metres ...
  double min_turn_deg = 5.0;   ///< ... or degrees (the leader's key-scan spacing)
  /// Throws std::invalid_argument naming the field ("contribute.<field>").
  void validate() const;
};

/// Whether a scan tracked at `pose` with fitness terms `value` is worth sending, the last scan
/// sent having been at `last_sent` (none yet: only the evidence counts).
bool worth_contributing(const ContributorConfig& config, const FitnessValue& value,
                        const Pose2& pose, const std::optional<Pose2>& last_sent);

/// Share of the beams of `points` seen from `pose` that pass through a cell with
/// hit >= min_hits and hit >= 2 err more than `margin` metres before their end point.
float occupied_contradiction(const GridMap& map, const ScanPoints& points, const Pose2& pose,
                             int min_hits, double margin);

}  // namespace esfleet
