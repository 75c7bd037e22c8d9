#pragma once
// The leader's SLAM pipeline (paper Algorithm 2): for every scan
//   1. predict the pose, 2. search it with the (mu+1)-ES against the map built from all earlier
//   scans, 3. update the map with this scan at the pose found.
// The very first scan is inserted at the origin.
//
// SlamConfig::paper() is the paper's exact configuration. The defaults add what the paper's
// SLAM needed to stay on track on the benchmark logs (docs/slam.md has the measurements):
// constant-velocity prediction, every motion hypothesis in the initial population, a wider
// initial spread, bilinear sub-cell fitness, a deterministic polish of the ES result, a motion
// prior that breaks ties in corridors, inserting scans only after the robot moved, a wide
// recovery search when the match is weak or the motion large (and weak scans kept out of the
// map), and loop closure over a pose graph of the inserted scans.

#include <cstdint>
#include <deque>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "esfleet/core/contribution.hpp"
#include "esfleet/core/es_search.hpp"
#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/loop_closure.hpp"
#include "esfleet/core/map_update.hpp"
#include "esfleet/core/pose_graph.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/core/recovery.hpp"
#include "esfleet/core/scan_points.hpp"
#include "esfleet/core/tracking.hpp"

namespace esfleet {

/// The leader's SLAM: its map, the per-scan tracking, scan insertion and loop closure.
struct SlamConfig {
  GridMapConfig map;
  MapUpdateConfig update;
  /// The per-scan pose search (ES, fitness, prediction, hypotheses, prior; tracking.hpp), the
  /// part of the SLAM a follower's localiser shares.
  TrackingConfig tracking;
  std::uint64_t seed = 1;  ///< seeds the ES; same input + seed = same trajectory

  // --- Beyond the paper (ours). SlamConfig::paper() switches all of these off. ---
  /// Write a scan into the map only once the pose moved this far from the last inserted one
  /// (either threshold; 0 and 0 = every scan, as in the paper).
  double insert_min_travel = 0.1;    ///< metres
  double insert_min_turn_deg = 5.0;  ///< degrees
  /// Loop closure over a pose graph of the inserted scans.
  LoopClosureConfig loop;
  double key_sigma_xy = 0.02;        ///< graph edge between consecutive inserted scans, metres
  double key_sigma_theta_deg = 0.3;  ///< ... degrees
  /// A weak match, or a large motion the tracking did not match well, triggers a wide
  /// correlative search, and a scan that still agrees poorly with the map is not written into
  /// it (recovery.hpp; on by default, off in the paper's configuration).
  RecoveryConfig recovery;
  /// Scans contributed by followers (Slam::contribute; contribution.hpp).
  ContributionConfig contribution;
  /// A short laser, with odometry: while no scan written into the map so far had a beam as
  /// long as short_view_range, the tracking holds along the motion (TrackingConfig::
  /// motion_hold) with at least short_view_motion_hold. Such a laser sees no end of a corridor
  /// it drives along, so the scan cannot tell how far the robot went; without the hold the
  /// pose slid against the odometry where an earlier pass's drifted map pulled it (CSAIL with
  /// an 8 m laser and noisy odometry broke on 2 of seeds 1-10, docs/benchmarks.md). A laser
  /// that has seen farther is left as it is: on the full logs the hold cost accuracy. 0 = off.
  double short_view_range = 10.0;       ///< metres
  double short_view_motion_hold = 0.1;  ///< share of the fitness (TrackingConfig::motion_hold)

  /// Throws std::invalid_argument naming the field.
  void validate() const;
  /// The paper's configuration: previous-pose prediction, laser only, Condition 1, initial
  /// spread 5 cm / 2 degrees, every scan inserted, none of our extensions.
  static SlamConfig paper();
};

/// What happened to one scan.
struct SlamStep {
  Pose2 pose;                   ///< the pose estimate for this scan
  Pose2 predicted;              ///< the prediction the search started from
  FitnessValue fitness;         ///< fitness terms at `pose` (before this scan's map update)
  bool inserted = false;        ///< whether the scan was written into the map
  bool loop_closed = false;     ///< a loop closure was accepted and the graph re-optimised
  bool recovery_tried = false;  ///< the recovery search ran (a weak match or a large motion)
  bool recovered = false;       ///< ... and its pose replaced the tracked one
  /// Due for insertion but too weak a match (or a pose beyond any map): not written.
  bool withheld = false;
  MapUpdateStats update;
  double search_ms = 0.0;  ///< wall time of the pose search (ES and polish)
  double update_ms = 0.0;  ///< wall time of the map update
  double loop_ms = 0.0;    ///< wall time of key-scan bookkeeping and loop closure
};

/// The last accepted loop closure, for logs.
struct LoopEvent {
  std::size_t key = 0;     ///< key scan that closed the loop
  std::size_t anchor = 0;  ///< old key scan it was matched to
  Pose2 correction;        ///< matched pose relative to the estimate before closing
  float agreement = 0.0f;
  double ambiguity = 0.0;
};

/// Everything besides the map that Slam::process depends on. With the map's counters it lets a
/// new Slam (same config) continue exactly where another one was: the leader's checkpoints
/// (slam_snapshot.hpp).
struct SlamState {
  Rng::State rng;
  std::vector<TimedPose> trajectory;
  std::optional<Pose2> last_odometry;
  std::optional<Pose2> last_inserted;
  double path_length = 0.0;
  std::vector<KeyScan> keys;
  std::vector<Pose2> graph_nodes;
  std::vector<PoseGraphEdge> graph_edges;
  /// Per trajectory entry: its key scan and its pose relative to it (loop closure on).
  std::vector<std::pair<std::size_t, Pose2>> anchors;
  std::size_t loop_closures = 0;
  std::size_t loop_rejected = 0;
  std::optional<LoopEvent> last_loop;
  /// A loop-closure search started at this key scan whose result is not applied yet
  /// (LoopClosureConfig::defer_keys); restore() starts it again.
  std::optional<std::size_t> pending_loop_key;
  /// The robots that contributed key scans (KeyScan::contributor k is contributors[k - 1]).
  std::vector<std::string> contributors;
  /// The last scan's pose was a recovery jump (Slam::process_scan).
  bool last_jumped = false;
};

/// What Slam::finish did.
struct SlamFinish {
  std::size_t tried = 0;    ///< key scans matched against their surroundings from other times
  std::size_t matched = 0;  ///< ... with an acceptable match (graph edges added)
  std::size_t kept = 0;     ///< ... that the optimised graph agreed with
  std::size_t icp_tried =
      0;  ///< pairs of nearby own key scans aligned by ICP (final_icp_neighbours)
  std::size_t icp_aligned = 0;  ///< ... whose alignment held (graph edges)
  std::size_t icp_held = 0;     ///< ... of which one direction kept the tracked translation
  double ms = 0.0;
};

class Slam {
 public:
  explicit Slam(SlamConfig config = {});

  /// Processes one scan. The scan's odometry is read only when use_odometry is on.
  SlamStep process(const LaserScan& scan);
  /// A scan a follower contributed with its pose (contribution.hpp): checked against the map,
  /// refined, and when accepted written into the map at the refined pose and added to the
  /// pose graph. Settles any speculative loop-closure search first. The result depends only
  /// on the state, the contribution and the seed (the refine draws from its own stream, seeded
  /// from the seed, the robot and seq), not on thread timing.
  ContributionResult contribute(const Contribution& c);
  /// Key scans contributed (accepted) so far.
  std::size_t contributed_keys() const { return contributed_keys_; }
  /// The robots that contributed (SlamState::contributors).
  const std::vector<std::string>& contributors() const { return contributors_; }
  /// The key scans (mapped pose, contributor; graph order).
  const std::vector<KeyScan>& keys() const { return keys_; }
  /// Key scan k's pose in the optimised graph.
  const Pose2& key_pose(std::size_t k) const { return graph_.node(k); }

  /// Once the input has ended: applies a pending loop-closure search and runs the final pass
  /// (LoopClosureConfig::final_pass), which moves past poses and re-writes the map. Further
  /// process() calls are allowed (the map and graph stay consistent). The final pass's searches
  /// run on `threads` threads; the result is the same for any number. One by default: each
  /// more thread keeps its own malloc arena of submap tiles (CSAIL: 47.0 -> 50.8 MB peak RSS
  /// with 2), for a pass that takes 2 s on CSAIL, 10 s on fr079.
  SlamFinish finish(unsigned threads = 1);

  const SlamConfig& config() const { return config_; }
  const GridMap& map() const { return map_; }
  GridMap& map() { return map_; }
  /// One pose per processed scan; with loop closure, past poses move when the graph is
  /// re-optimised.
  const std::vector<TimedPose>& trajectory() const { return trajectory_; }
  std::size_t scans_processed() const { return trajectory_.size(); }
  std::size_t loop_closures() const { return loop_closures_; }
  std::size_t loop_closures_rejected() const { return loop_rejected_; }
  std::size_t key_scans() const { return keys_.size(); }
  /// The longest beam of the leader's own key scans so far, metres (SlamConfig::
  /// short_view_range compares it).
  float laser_reach() const { return laser_reach_; }
  /// Whether the next scan with odometry is tracked with the short laser's hold: odometry on,
  /// the hold on, and laser_reach() under SlamConfig::short_view_range.
  bool short_view_hold() const {
    return config_.tracking.use_odometry && config_.short_view_motion_hold > 0.0 &&
           laser_reach_ < config_.short_view_range;
  }
  const std::optional<LoopEvent>& last_loop() const { return last_loop_; }

  /// Waits for a loop-closure search still running speculatively
  /// (LoopClosureConfig::speculate) and applies its result: afterwards state() and the map
  /// are what they would be with the search on the mapping thread. Returns true when it closed
  /// a loop (the map and past poses changed).
  bool settle();
  /// Whether a speculative loop-closure search is still running (settle() ends it).
  bool speculating() const { return !speculations_.empty(); }

  /// A copy of the state besides the map (see SlamState). Throws std::logic_error while
  /// speculating(): call settle() first.
  SlamState state() const;
  /// Replaces the state besides the map (the map is restored through map()). Throws
  /// std::invalid_argument naming the field when the parts do not fit together (graph nodes
  /// vs key scans, anchors vs trajectory, edge or anchor indices out of range).
  void restore(SlamState state);

 private:
  /// The recovery search for a weak match or a large predicted motion (SlamConfig::recovery):
  /// replaces step.pose and step.fitness when it finds a clearly more consistent pose.
  void recover(const LaserScan& scan, const ScanPoints& points, const MotionState& motion,
               const Pose2& predicted, SlamStep& step);
  /// Adds the scan just inserted as a key scan (graph node + edge to the previous one),
  /// applies a deferred loop-closure search that is due and starts a new one when it is time;
  /// returns true when the graph was re-optimised.
  bool add_key_scan(const ScanPoints& points, const Pose2& pose, double stamp);
  /// Whether a scan found at `pose` is far from the ones before it, as the beam fill wants
  /// (MapUpdateConfig::beam_fill_min_step).
  bool scans_far_apart(const Pose2& pose) const;
  /// Starts the loop-closure search for key scan k against the older key scans at their
  /// current graph poses (a copy of the few it needs; on a worker thread when deferred or
  /// speculative). Returns false, starting nothing, when too few old scans are near it.
  bool start_loop_search(std::size_t k);
  /// Waits for the pending search and turns its match, if any, into a graph edge; returns
  /// true when the closure was accepted and the graph re-optimised.
  bool finish_loop_search();
  /// Moves every key scan whose optimised pose differs from where it is in the map, and
  /// re-derives the trajectory from the optimised key poses.
  void apply_graph();
  /// The final pass's ICP edges (LoopClosureConfig::final_icp_neighbours) into `edges`, the
  /// graph's edges: the chain edge into each own key scan takes the alignment with the one
  /// before; the older neighbours' alignments are added. Deterministic for any `threads`.
  void add_icp_edges(std::vector<PoseGraphEdge>& edges, unsigned threads, SlamFinish& out) const;
  /// laser_reach_ from the own key scans, after they were replaced or cut back.
  void recompute_laser_reach();
  /// The edge between two of the leader's own key scans (key edge weights).
  PoseGraphEdge key_edge(std::size_t from, std::size_t to, const Pose2& measurement) const;

  SlamConfig config_;
  GridMap map_;
  EvolutionStrategy es_;
  Rng rng_;
  std::vector<TimedPose> trajectory_;
  std::optional<Pose2> last_odometry_;
  std::optional<Pose2> last_inserted_;
  double path_length_ = 0.0;
  /// The last pose was a recovery jump: the next prediction continues the motion before it.
  bool last_jumped_ = false;
  /// The longest beam of the leader's own key scans (SlamConfig::short_view_range).
  float laser_reach_ = 0.0f;
  /// config_.tracking with the short laser's hold (SlamConfig::short_view_motion_hold).
  TrackingConfig short_view_tracking_;

  std::vector<KeyScan> keys_;
  /// The leader's own last key scan (contributed ones come in between).
  std::size_t last_own_key_ = 0;
  std::vector<std::string> contributors_;
  std::size_t contributed_keys_ = 0;
  /// Per contributor (index into contributors_): its last accepted key scan, the pose it
  /// claimed there, and the travel along its chain since its last anchor edge.
  struct ContributorChain {
    std::size_t key = 0;
    Pose2 claimed;
    double unanchored_travel = 0.0;
  };
  std::vector<std::optional<ContributorChain>> chains_;
  PoseGraph graph_;
  /// For each trajectory entry: the key scan it is anchored to and its pose relative to it.
  std::vector<std::pair<std::size_t, Pose2>> anchors_;
  std::size_t loop_closures_ = 0;
  std::size_t loop_rejected_ = 0;
  std::optional<LoopEvent> last_loop_;
  struct PendingLoop {
    std::size_t key = 0;
    Pose2 estimate;  ///< key scan `key`'s graph pose when the search started
    std::shared_future<std::optional<LoopMatch>> match;
  };
  std::optional<PendingLoop> pending_loop_;
  /// The online searches' last submap (loop_closure.hpp): searches run one after another, the
  /// mutex only guards against a second one running at once.
  struct SharedSubmap {
    std::mutex mutex;
    SubmapCache cache;
  };
  std::shared_ptr<SharedSubmap> submap_ = std::make_shared<SharedSubmap>();
  /// A speculative search and what it needs to go back to its key scan if it closes the loop:
  /// the state right after that key scan was added, and the scans since.
  struct Speculation {
    PendingLoop search;
    Rng::State rng;
    std::size_t trajectory_size = 0;
    std::optional<Pose2> last_odometry;
    std::optional<Pose2> last_inserted;
    double path_length = 0.0;
    bool last_jumped = false;
    /// The graph at the key scan is the first this many nodes and edges of graph_: while
    /// searches are speculative the graph only grows at its end (a closure, a contribution and
    /// the final pass come after settling), so no copy is kept.
    std::size_t graph_nodes = 0;
    std::size_t graph_edges = 0;
    std::vector<LaserScan> scans;
  };
  /// Oldest first; their searches run one after another on worker threads and are applied
  /// in this order (a later one started from the state the earlier one may undo).
  std::deque<Speculation> speculations_;
  /// Applies the oldest speculative search; true when it closed the loop.
  bool settle_one();
  /// Processing the scans of an undone speculation again: searches run on this thread.
  bool replaying_ = false;
  SlamStep process_scan(const LaserScan& scan);
  /// The pending search's match as a graph edge on `graph` (the graph at the search's key
  /// scan): true and the optimised graph if the graph can take it (cost increase <= max_chi2).
  bool accept_loop(const LoopMatch& match, std::size_t k, PoseGraph& graph) const;
};

}  // namespace esfleet
