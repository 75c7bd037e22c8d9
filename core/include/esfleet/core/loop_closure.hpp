#pragma once
// Loop-closure detection for the leader's SLAM (ours, beyond the paper; the paper's SLAM never
// revisits its past and names getting stuck as its weakness). When the robot comes back near
// places it mapped long ago (far back along its own path), the current scan is matched against
// a submap built from those old scans only, with a brute-force search over a window on a
// coarse level followed by a fine polish. A match is accepted only if it agrees with the old
// map (agreement, share of end points on known cells) and is unambiguous (no comparable score
// far from the best, as in a corridor). The caller turns an accepted match into a pose-graph
// edge.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/map_update.hpp"
#include "esfleet/core/scan_icp.hpp"
#include "esfleet/core/scan_points.hpp"

namespace esfleet {

/// A scan written into the map, kept so loop closure can match against it and move it.
struct KeyScan {
  double stamp = 0.0;
  /// Never null and never changed once made: shared by the SLAM and the copies of its state
  /// (Slam::state(), taken at every checkpoint), which would otherwise duplicate every key
  /// scan's points (CSAIL: 8 MB).
  std::shared_ptr<const ScanPoints> points = std::make_shared<const ScanPoints>();
  Pose2 mapped_pose;         ///< the pose its counters are in the map at
  double path_length = 0.0;  ///< distance travelled from the start to here (estimate), metres
  /// 0: the leader's own scan; k > 0: contributed by robot SlamState::contributors[k - 1]
  /// (contribution.hpp). A contributed scan's path_length is kContributedPathLength, so every
  /// loop-closure search of the leader may use it and none starts from it.
  std::uint32_t contributor = 0;
};

/// KeyScan::path_length of a contributed scan: far back along any path.
inline constexpr double kContributedPathLength = -1e9;

struct LoopClosureConfig {
  bool enabled = true;
  int every = 5;  ///< attempt once per this many key scans
  /// No attempt for this many key scans after an accepted closure: a robot going round a
  /// mapped place would otherwise close (and re-write the map) every few metres.
  int cooldown = 20;
  double min_travel = 10.0;     ///< old = at least this far back along the path, metres
  double search_radius = 6.0;   ///< old scans within this of the current estimate trigger
  double submap_radius = 10.0;  ///< old scans within this form the submap, metres
  int max_submap_scans = 60;    ///< nearest ones first
  double window_xy = 2.0;       ///< search window +-, metres
  /// The window grows to the plausible drift (drift_floor_xy + drift_rate_xy * travel since
  /// the nearest old scan), up to this (<= window_xy: fixed window). After a long loop with
  /// a stretch of corridor drift (CSAIL laser only, scans 1040-1250) the revisit can be 2-4.6 m
  /// off; a fixed 2 m window then never closes it and the run breaks (docs/slam.md).
  double window_max_xy = 4.0;
  double window_theta_deg = 15.0;  ///< search window +-, degrees
  double min_agreement = 0.75;     ///< FitnessValue::agreement of the match
  double min_known = 0.5;          ///< share of end points on known submap cells
  double max_ambiguity =
      0.7;  ///< best score > rival_distance away / best score must stay below this
  double rival_distance = 1.0;  ///< metres (see max_ambiguity)
  /// A match whose translation the submap constrains along one direction less than this share
  /// of the other (flattest_direction of the fine fitness at the match: a corridor's axis) keeps
  /// the estimate's position along that direction; only the rest of the correction is taken. 0 =
  /// off. The online searches leave it off; the final pass uses final_degenerate_ratio.
  double degenerate_ratio = 0.0;
  /// Plausibility: the correction a match implies must stay below floor + rate * (distance
  /// travelled since the anchor scan); odometry-free drift rarely exceeds a few percent.
  double drift_floor_xy = 0.3;         ///< metres
  double drift_rate_xy = 0.02;         ///< metres per metre travelled
  double drift_floor_theta_deg = 2.0;  ///< degrees
  double drift_rate_theta_deg = 0.05;  ///< degrees per metre travelled
  /// A closure is kept only if, after optimising, the graph's total cost grew by at most this
  /// (whitened squared error): a closure the graph must strain to satisfy is dropped.
  double max_chi2 = 16.0;
  double sigma_xy = 0.05;        ///< loop edge standard deviation, metres
  double sigma_theta_deg = 1.0;  ///< loop edge standard deviation, degrees
  double huber = 2.0;            ///< Huber threshold of loop edges (whitened)
  /// After optimising, a key scan is re-written into the map only if its pose moved at least
  /// this much: smaller moves (under half a 5 cm cell) barely change the map but make the
  /// leader republish tiles (fr079: 0.5 cm / 0.05 deg sent 22 MB of tile deltas after loop
  /// closures, 2 cm / 0.2 deg 15 MB at the same accuracy; docs/benchmarks.md).
  double move_min_xy = 0.02;        ///< metres
  double move_min_theta_deg = 0.2;  ///< degrees
  /// 0 (default): the search for a closure at key scan k runs and is applied at key k, on the
  /// calling thread. N > 0: it runs on a worker thread and its result is applied (graph edge,
  /// optimisation, map re-write) when key scan k + N is added, never earlier, waiting for the
  /// worker if needed, so the trajectory does not depend on thread timing. At most `every`.
  /// Not the default: on CSAIL (laser only) seed 4 it broke the trajectory with N = 3 and 5
  /// (docs/benchmarks.md, "SLAM speed").
  int defer_keys = 0;
  /// With defer_keys 0: the search for key scan k runs on a worker thread while the mapping
  /// thread goes on with the next scans speculatively. The result is then judged as at key k
  /// (on a copy of the graph as it was); only an accepted closure undoes the scans since key k
  /// (map, trajectory, key scans, random state) and processes them again after applying it.
  /// The result is the same as with the search on the mapping thread, bit for bit; the search
  /// costs the mapping thread nothing unless it closes a loop.
  bool speculate = true;
  /// Final pass (Slam::finish): every key scan matched against the key scans near it from
  /// other times (at least min_travel away along the path) in a small window around its graph
  /// pose, the matches added as graph edges, the graph optimised with the outliers dropped.
  bool final_pass = true;
  int final_every = 3;                  ///< every N-th key scan is matched
  int final_rounds = 1;                 ///< match again from the optimised poses this often
  double final_window_xy = 0.3;         ///< metres
  double final_window_theta_deg = 3.0;  ///< degrees
  double final_submap_radius = 6.0;     ///< metres
  int final_max_submap_scans = 30;
  double final_rival_distance = 0.3;  ///< metres
  double final_max_ambiguity = 0.9;
  /// degenerate_ratio of the final pass's searches. Along a corridor its small window's
  /// best match slid 0.2-0.8 m where the tracked chain was right (CSAIL with odometry, seeds
  /// 4 and 5: the revisit of scans 622-634 at 1564-1590; docs/slam.md item 6).
  double final_degenerate_ratio = 0.1;
  double final_max_edge_chi2 = 9.0;  ///< whitened; edges above it after optimising are dropped
  /// Final pass: each inserted scan is aligned by ICP (scan_icp.hpp) to the N inserted scans
  /// before it. Where the ICP holds, the graph edge from the previous one takes its result in
  /// place of the tracked motion, and the older ones become edges of their own (key edge
  /// weights). 0 = off.
  int final_icp_neighbours = 0;
  double final_icp_max_distance = 0.5;  ///< pairs of scans farther apart are not aligned, metres
  IcpConfig icp;
  void validate() const;
};

struct LoopMatch {
  std::size_t anchor = 0;  ///< index of the old key scan the measurement is relative to
  Pose2 pose;              ///< the current scan's pose in the (old) map frame
  Pose2 relative;          ///< pose relative to the anchor's pose
  FitnessValue value;      ///< fine fitness terms at `pose` in the submap
  double ambiguity = 0.0;  ///< second-best distinct score / best score (coarse)
  std::size_t submap_scans = 0;
};

/// The translation window (+-, metres) of a search whose nearest old scan is `travel` metres
/// back along the path: window_xy grown to the plausible drift, at most window_max_xy.
double loop_search_window_xy(const LoopClosureConfig& config, double travel);

/// One scan of a submap: its points (never changed once made) at a pose.
struct SubmapScan {
  std::shared_ptr<const ScanPoints> points;
  Pose2 pose;
};

/// The last submap a loop-closure search built, kept to build the next one from. Consecutive
/// searches (every 5th key scan) mostly use the same old scans at the same poses: the scans
/// no longer in it, or moved since (a closure re-optimised the graph), are taken back out
/// (their counters removed exactly) and only the new ones are ray-cast. The counters are
/// integers and the scores follow from them, so every cell is what a submap built from scratch
/// holds, bit for bit (loop_closure_test); tiles that only the removed scans touched stay, all
/// unknown. Built from scratch instead when that is cheaper, or when such leftover tiles have
/// doubled the submap's size. One search at a time (not thread-safe); the scans are held by
/// their shared pointers, so a scan's identity (its points' address) is never reused while
/// it is remembered.
class SubmapCache {
 public:
  /// trim() frees a submap of more than `max_kept_tiles` tiles (about 53 kB each with the
  /// loop closure's two coarse levels).
  explicit SubmapCache(std::size_t max_kept_tiles = 32) : max_kept_tiles_(max_kept_tiles) {}
  /// The submap of `scans` (update_map of each at its pose, committed), with at least
  /// `pyramid_levels` coarse levels. The configurations must be the same on every call.
  const GridMap& build(const std::vector<SubmapScan>& scans, const GridMapConfig& map_config,
                       const MapUpdateConfig& update_config);
  /// Scans ray-cast in or out over all calls (for tests and statistics).
  std::size_t scans_cast() const { return scans_cast_; }
  /// Frees the submap (the next build starts from scratch).
  void clear() {
    map_.reset();
    members_.clear();
  }
  /// After a search: frees the submap if it is larger than the cache keeps between searches
  /// (a bound on the memory it holds while the mapping thread runs).
  void trim();

 private:
  void cast(const SubmapScan& scan, const MapUpdateConfig& config, bool remove);
  std::size_t max_kept_tiles_;
  std::unique_ptr<GridMap> map_;
  std::vector<SubmapScan> members_;
  std::size_t fresh_tiles_ = 0;
  std::size_t scans_cast_ = 0;
};

/// Looks for a loop closure of the scan `points` whose current estimate is `estimate` and
/// whose path length is `path_length`, against `keys` with their current poses `poses`
/// (indices shared). Returns nothing when there are no old scans near or no acceptable match.
/// With `cache`, the submap is built from the previous search's (the same result).
std::optional<LoopMatch> find_loop_closure(
    const std::vector<KeyScan>& keys, const std::vector<Pose2>& poses, const ScanPoints& points,
    const Pose2& estimate, double path_length, const LoopClosureConfig& config,
    const GridMapConfig& map_config, const MapUpdateConfig& update_config,
    const FitnessOptions& fitness, SubmapCache* cache = nullptr);

}  // namespace esfleet
