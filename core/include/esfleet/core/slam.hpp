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
  Pose2 predict(const LaserScan& scan) const;

  SlamConfig config_;
  GridMap map_;
  EvolutionStrategy es_;
  Rng rng_;
  std::vector<TimedPose> trajectory_;
  std::optional<Pose2> last_odometry_;
};

}  // namespace esfleet
