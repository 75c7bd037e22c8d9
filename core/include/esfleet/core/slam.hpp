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
#include "esfleet/core/loop_closure.hpp"
#include "esfleet/core/map_update.hpp"
#include "esfleet/core/pose_graph.hpp"
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
  int coarse_stride = 1;                ///< use every n-th beam at the coarse level
  double coarse_sigma_xy = 0.2;         ///< initial spread at the coarse level, metres
  double coarse_sigma_theta_deg = 8.0;  ///< initial spread at the coarse level, degrees
  /// Full-resolution fitness with bilinear interpolation of map values between cell centres
  /// (sub-cell precision; the penalty still counts the end point's own cell).
  bool interpolate = false;
  /// Motion prior (0 = off): the ES maximises fitness * max_h exp(-m_h^2 / 2), m_h the
  /// distance to motion hypothesis h in units of these sigmas. A tie-breaker for directions the
  /// map does not constrain (corridors); wide enough not to fight a clear match.
  double prior_sigma_xy = 0.0;         ///< metres
  double prior_sigma_theta_deg = 0.0;  ///< degrees
  bool prior_centre_only = false;      ///< prior around the centre prediction only
  /// After the ES, polish the best pose with a deterministic pattern search (refine_pose).
  bool refine = false;
  /// Write a scan into the map only once the pose moved this far from the last inserted one
  /// (either threshold; 0 and 0 = every scan, as in the paper).
  double insert_min_travel = 0.0;    ///< metres
  double insert_min_turn_deg = 0.0;  ///< degrees
  /// Agreement (FitnessValue::agreement) is tracked as a running median over recent inserted
  /// scans. A match whose agreement falls below retry_ratio * median is searched again with a
  /// wide initial spread (the better result wins); below gate_ratio * median it is not written
  /// into the map. 0 = off.
  double retry_ratio = 0.0;
  double retry_sigma_xy = 0.3;          ///< metres
  double retry_sigma_theta_deg = 20.0;  ///< degrees
  double gate_ratio = 0.0;
  /// Loop closure with a pose graph over the inserted scans (off in the paper's configuration).
  LoopClosureConfig loop;
  double key_sigma_xy = 0.02;        ///< pose-graph edge between consecutive inserted scans, m
  double key_sigma_theta_deg = 0.3;  ///< ... degrees

  /// Throws std::invalid_argument naming the field.
  void validate() const;
  /// The paper's configuration: previous-pose prediction, laser only, Condition 1, none of our
  /// extensions.
  static SlamConfig paper();
};

/// What happened to one scan.
struct SlamStep {
  Pose2 pose;                ///< the pose estimate for this scan
  Pose2 predicted;           ///< the prediction the search started from
  FitnessValue fitness;      ///< fitness terms at `pose` (before this scan's map update)
  bool inserted = false;     ///< whether the scan was written into the map
  bool retried = false;      ///< whether the wide retry search ran
  bool loop_closed = false;  ///< a loop closure was accepted and the graph re-optimised
  MapUpdateStats update;
  double search_ms = 0.0;  ///< wall time of the pose search (ES, retries, polish)
  double update_ms = 0.0;  ///< wall time of the map update
  double loop_ms = 0.0;    ///< wall time of key-scan bookkeeping and loop closure
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
  std::size_t loop_closures() const { return loop_closures_; }
  std::size_t loop_closures_rejected() const { return loop_rejected_; }
  std::size_t key_scans() const { return keys_.size(); }

 private:
  /// The pose the search is centred on; `alternatives` receives every motion hypothesis.
  Pose2 predict(const LaserScan& scan, std::vector<Pose2>* alternatives) const;
  FitnessOptions fitness_options(int level) const;
  float prior(const Pose2& p, const std::vector<Pose2>& hypotheses) const;
  EsResult polish(const ScanPoints& points, const Pose2& start,
                  const std::vector<Pose2>& hypotheses) const;
  EsResult search(const ScanPoints& points, const Pose2& centre,
                  const std::vector<Pose2>& alternatives, double sigma_scale = 1.0);

  SlamConfig config_;
  GridMap map_;
  EvolutionStrategy es_;
  Rng rng_;
  std::vector<TimedPose> trajectory_;
  std::optional<Pose2> last_odometry_;
  std::optional<Pose2> last_inserted_;
  std::vector<float> recent_agreement_;  ///< ring of agreements of recent inserted scans
  std::size_t agreement_next_ = 0;
  float median_agreement() const;
  /// Adds the scan just inserted as a key scan (graph node + edge to the previous one) and
  /// tries a loop closure; returns true when the graph was re-optimised.
  bool add_key_scan(const ScanPoints& points, const Pose2& pose, double stamp);
  /// Moves every key scan whose optimised pose differs from where it is in the map, and
  /// re-derives the trajectory from the optimised key poses.
  void apply_graph();

  std::vector<KeyScan> keys_;
  PoseGraph graph_;
  /// For each trajectory entry: the key scan it is anchored to and its pose relative to it.
  std::vector<std::pair<std::size_t, Pose2>> anchors_;
  double path_length_ = 0.0;
  std::size_t loop_closures_ = 0;
  std::size_t loop_rejected_ = 0;
};

}  // namespace esfleet
