#pragma once
// One pose-tracking step against a fixed map: predict the pose of a new scan from the past
// estimates (and odometry), search it with the (mu+1)-ES, polish it. The leader's SLAM (slam.hpp)
// and the follower's localiser (localiser.hpp) share it, so a follower tracks exactly as the
// leader maps. The configuration is the SLAM's (SlamConfig): the ES parameters, prediction,
// hypotheses, interpolation, prior.

#include <optional>
#include <vector>

#include "esfleet/core/es_search.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/core/scan_points.hpp"
#include "esfleet/core/slam.hpp"

namespace esfleet {

/// What the motion prediction knows of the past.
struct MotionState {
  TimedPose last;                     ///< the last estimate
  std::optional<TimedPose> previous;  ///< the one before it, if any
  std::optional<Pose2> odometry;      ///< odometry reading of the last scan, if any
};

/// The pose the search is centred on (odometry increment when switched on and present, else
/// constant velocity or the previous pose, per config.prediction); `alternatives` (optional)
/// receives the other motion hypotheses (see SlamConfig::motion_hypotheses, turn_hypotheses).
Pose2 predict_pose(const SlamConfig& config, const MotionState& motion, const LaserScan& scan,
                   std::vector<Pose2>* alternatives);

struct TrackResult {
  Pose2 predicted;  ///< where the search was centred
  EsResult result;  ///< the pose found and its fitness terms (result.value)
};

/// Predicts, searches (ES with config.es from an initial population around the prediction and
/// the motion hypotheses, times the motion prior when on) and polishes (config.refine) the pose
/// of `points` (prepared from `scan`) in `map`. Draws from `rng`.
TrackResult track_scan(const SlamConfig& config, const EvolutionStrategy& es, Rng& rng,
                       const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                       const MotionState& motion);

/// The fitness options the SLAM uses (penalty per config, bilinear when `interpolate`).
FitnessOptions slam_fitness_options(const SlamConfig& config, bool interpolate);

}  // namespace esfleet
