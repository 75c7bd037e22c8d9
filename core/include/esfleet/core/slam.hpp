#pragma once
// The leader's SLAM pipeline (paper Algorithm 2): for every scan
//   1. predict the pose, 2. search it with the (mu+1)-ES against the map built from all earlier
//   scans, 3. update the map with this scan at the pose found.
// The very first scan is inserted at the origin.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "esfleet/core/es_search.hpp"
#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/map_update.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet {

enum class MotionPrediction {
  kPreviousPose,      ///< the previous estimate (the paper's correction to "the current position")
  kConstantVelocity,  ///< previous estimate plus the last inter-scan motion, scaled by time
};

struct SlamConfig {
  GridMapConfig map;
  MapUpdateConfig update;
  EsConfig es;
  bool use_penalty = true;    ///< fitness with p_occ (paper Condition 1); false = Condition 2
  bool use_odometry = false;  ///< add the odometry increment to the prediction (paper: off)
  MotionPrediction prediction = MotionPrediction::kPreviousPose;  ///< used without odometry
  float min_range = 0.0f;  ///< beams shorter than this are ignored (m)
  float max_range = 0.0f;  ///< beams at or beyond this are ignored (m); 0 = sensor maximum
  /// Initial population: zero correction plus mu-1 draws N(0, sigma) around the prediction.
  double init_sigma_xy = 0.05;        ///< metres
  double init_sigma_theta_deg = 2.0;  ///< degrees
  std::uint64_t seed = 1;             ///< seeds the ES; same input + seed = same trajectory

  // --- Beyond the paper (ours). SlamConfig::paper() switches all of these off. ---
  /// Seed the initial population with every motion hypothesis available (previous pose,
  /// constant velocity, odometry), not only the one the search is centred on.
  bool motion_hypotheses = false;
  /// Coarse-to-fine: run the first `coarse_iterations` ES iterations on map pyramid level
  /// `coarse_level` (cells 2^level larger, max-pooled), then the rest at full resolution from the
  /// coarse population. 0 = single-level search as in the paper. Needs map.pyramid_levels >= it.
  int coarse_level = 0;
  int coarse_iterations = 500;
  int coarse_stride = 1;                 ///< use every n-th beam at the coarse level
  double coarse_sigma_xy = 0.2;          ///< initial spread at the coarse level, metres
  double coarse_sigma_theta_deg = 8.0;   ///< initial spread at the coarse level, degrees

  /// Throws std::invalid_argument naming the field.
  void validate() const;
  /// The paper's configuration: previous-pose prediction, laser only, Condition 1, none of our
  /// extensions.
  static SlamConfig paper();
};

/// What happened to one scan.
struct SlamStep {
  Pose2 pose;             ///< the pose estimate for this scan
  Pose2 predicted;        ///< the prediction the search started from
  FitnessValue fitness;   ///< fitness terms at `pose` (before this scan's map update)
  bool inserted = false;  ///< whether the scan was written into the map
  MapUpdateStats update;
};

class Slam {
 public:
  explicit Slam(SlamConfig config = {});

  /// Processes one scan. The scan's odometry is read only when use_odometry is on.
  SlamStep process(const LaserScan& scan);

  const SlamConfig& config() const { return config_; }
  const GridMap& map() const { return map_; }
  GridMap& map() { return map_; }
  const std::vector<TimedPose>& trajectory() const { return trajectory_; }
  std::size_t scans_processed() const { return trajectory_.size(); }

 private:
  /// The pose the search is centred on; `alternatives` receives every motion hypothesis.
  Pose2 predict(const LaserScan& scan, std::vector<Pose2>* alternatives) const;
  EsResult search(const ScanPoints& points, const Pose2& centre,
                  const std::vector<Pose2>& alternatives);

  SlamConfig config_;
  GridMap map_;
  EvolutionStrategy es_;
  Rng rng_;
  std::vector<TimedPose> trajectory_;
  std::optional<Pose2> last_odometry_;
};

}  // namespace esfleet
