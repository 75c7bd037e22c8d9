#pragma once
// One pose-tracking step against a fixed map: predict the pose of a new scan from the past
// estimates (and odometry), search it with the (mu+1)-ES, polish it. The leader's SLAM (slam.hpp)
// and the follower's localiser (localiser.hpp) share it and both embed its configuration
// (TrackingConfig), so a follower tracks exactly as the leader maps.

#include <optional>
#include <vector>

#include "esfleet/core/es_search.hpp"
#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet {

enum class MotionPrediction {
  kPreviousPose,      ///< the previous estimate (the paper's correction to "the current position")
  kConstantVelocity,  ///< previous estimate plus the last inter-scan motion, scaled by time
};

/// Where the fitness interpolates map values bilinearly between cell centres (ours).
enum class Interpolation {
  kNone,    ///< nearest cell everywhere (the paper)
  kPolish,  ///< the ES uses nearest cells, the final polish interpolates
  kAll,     ///< ES and polish interpolate (4 look-ups per beam)
};

/// What the per-scan tracking step reads: the ES, the fitness, the motion prediction and
/// hypotheses, the polish and the motion prior, and the beams it matches. SlamConfig and
/// LocaliserConfig both embed one. The defaults are esfleet's; SlamConfig::paper() holds the
/// paper's values.
struct TrackingConfig {
  EsConfig es;
  bool use_penalty = true;    ///< fitness with p_occ (paper Condition 1); false = Condition 2
  bool use_odometry = false;  ///< predict with the odometry increment (paper: off)
  MotionPrediction prediction = MotionPrediction::kConstantVelocity;  ///< without odometry
  /// The beams matched (Slam and Localiser prepare each scan with these).
  float min_range = 0.0f;  ///< beams shorter than this are ignored (m)
  float max_range = 0.0f;  ///< beams at or beyond this are ignored (m); 0 = sensor maximum
  /// Initial population: zero correction (and the motion hypotheses) plus draws N(0, sigma)
  /// around the prediction.
  double init_sigma_xy = 0.1;         ///< metres
  double init_sigma_theta_deg = 8.0;  ///< degrees

  // --- Beyond the paper (ours). SlamConfig::paper() switches all of these off. ---
  /// Put every motion hypothesis (previous pose, constant velocity, odometry) into the initial
  /// population, not only the one the search is centred on. With odometry the previous pose
  /// is left out (in a corridor it would let the search stop the robot).
  bool motion_hypotheses = true;
  /// Laser only: also the constant-velocity pose turned by +-1 and +-2 times the last turn
  /// (turns that speed up, stop or reverse).
  bool turn_hypotheses = true;
  Interpolation interpolation = Interpolation::kAll;
  /// The ES scores only end points at least this far (metres) from the previous one it kept,
  /// in beam order (thin_scan); the polish and the reported fitness use every end point.
  /// 0 = every end point (the paper).
  double search_point_spacing = 0.1;
  /// Polish the ES result with a deterministic pattern search (refine_pose_with).
  bool refine = true;
  /// Motion prior (0 = off): the search maximises fitness * max_h exp(-m_h^2 / 2), m_h the
  /// distance to motion hypothesis h in units of these sigmas: a tie-breaker for directions
  /// the map does not constrain (corridors), wide enough not to fight a clear match.
  double prior_sigma_xy = 0.3;          ///< metres
  double prior_sigma_theta_deg = 10.0;  ///< degrees
  /// Laser only: the prior also favours the previous pose (a stop). Off: the previous pose is
  /// only in the initial population while another hypothesis says the robot moves.
  bool prior_on_stop = false;
  /// Hold along the motion (0 = off): after the search, where the map constrains one direction
  /// of the position much less than the other (the fitness's least curvature there at most
  /// motion_hold_ratio times its greatest: a corridor's axis), the pose moves along that
  /// direction onto the motion hypothesis nearest to it, if the fitness there is at least
  /// (1 - motion_hold) times the one found. Where the scan cannot tell how far the robot went,
  /// the motion says. The localiser's default (LocaliserConfig::motion_hold); the SLAM's is
  /// off (docs/localisation.md, Method).
  double motion_hold = 0.0;
  double motion_hold_ratio = 0.2;  ///< in [0, 1]; 1 = wherever the fitness is within tolerance

  /// Throws std::invalid_argument naming the field (as "slam.<field>": the SLAM flags set it).
  void validate() const;
};

/// The end points the tracking matches: prepare_scan with the config's range limits.
ScanPoints prepare_scan(const LaserScan& scan, const TrackingConfig& config);

/// What the motion prediction knows of the past.
struct MotionState {
  TimedPose last;                     ///< the last estimate
  std::optional<TimedPose> previous;  ///< the one before it, if any
  std::optional<Pose2> odometry;      ///< odometry reading of the last scan, if any
  /// Slam: when `last` is a recovery jump, `previous` continues the step before it (the jump
  /// taken as a correction of the estimate), and this is the estimate before the jump as it
  /// was tracked (the jump may instead have been the robot's own motion).
  std::optional<TimedPose> before_jump;
};

/// The share of the step from `a` to `b` that constant velocity predicts for a scan at `stamp`:
/// the time ratio (stamp - b) / (b - a), clamped to [0, 3]; 1 when the stamps give none.
double velocity_scale(const TimedPose& a, const TimedPose& b, double stamp);

/// `b` moved on by the step from `a` to `b` times velocity_scale(a, b, stamp).
Pose2 constant_velocity(const TimedPose& a, const TimedPose& b, double stamp);

/// The pose the search is centred on (odometry increment when switched on and present, else
/// constant velocity or the previous pose, per config.prediction); `alternatives` (optional)
/// receives the other motion hypotheses (see TrackingConfig::motion_hypotheses,
/// turn_hypotheses).
Pose2 predict_pose(const TrackingConfig& config, const MotionState& motion, const LaserScan& scan,
                   std::vector<Pose2>* alternatives);

struct TrackResult {
  Pose2 predicted;  ///< where the search was centred
  EsResult result;  ///< the pose found and its fitness terms (result.value)
};

/// Predicts, searches (ES with config.es from an initial population around the prediction and
/// the motion hypotheses, times the motion prior when on) and polishes (config.refine) the pose
/// of `points` (prepared from `scan`) in `map`. Draws from `rng`. An odometry prediction
/// beyond any map (beyond_any_map) is dropped: the scan is predicted as if without odometry.
TrackResult track_scan(const TrackingConfig& config, const EvolutionStrategy& es, Rng& rng,
                       const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                       const MotionState& motion);

/// The fitness options the SLAM uses (penalty per config, bilinear when `interpolate`).
FitnessOptions slam_fitness_options(const TrackingConfig& config, bool interpolate);

}  // namespace esfleet
