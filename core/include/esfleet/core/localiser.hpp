#pragma once
// The follower's self-localisation in a received map (ours, after the authors' multi-robot
// work; docs/localisation.md has the measurements):
//
//  1. Global search (no prior knowledge; global_search.hpp): candidate poses over the known
//     free space of the map and all headings, or around a hint.
//  2. Hypotheses: every candidate is tracked scan by scan with the same per-scan step as the
//     leader (tracking.hpp). A pose is declared only when one hypothesis has matched the map
//     well (agreement, known share) on `confirm_scans` consecutive scans, the robot has moved,
//     and no distinct rival scores close to it (a corridor or a symmetric room) unless the map
//     contradicts that rival far more often (the contradiction route, LocaliserConfig).
//  3. Tracking: the per-scan step on the declared hypothesis. When the match collapses for
//     `lost_scans` scans the localiser reports lost and searches globally again (kidnap).
//
// The map may grow between scans (a follower keeps applying tiles); the localiser reads it
// afresh on every scan. It never reads ground truth. Diagnostics (the hypotheses, the stages
// of each global search) go to a LocaliserObserver, not through the API.

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "esfleet/core/es_search.hpp"
#include "esfleet/core/evidence.hpp"
#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/global_search.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/laser_scan.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/core/scan_points.hpp"
#include "esfleet/core/tracking.hpp"

namespace esfleet {

enum class LocaliserState : std::uint8_t {
  kWaitingForMap,  ///< no map tiles yet
  kLocalising,     ///< searching, nothing declared yet
  kTracking,       ///< pose declared and followed
  kLost,           ///< was tracking, lost the match, searching again
};
const char* to_string(LocaliserState s);

/// The defaults are measured choices: docs/localisation.md ("Why these defaults") has the
/// measurements behind them.
struct LocaliserConfig {
  /// The per-scan tracking step, as the leader's SLAM runs it (ES, prediction, fitness; the
  /// follower takes it from the SLAM flags).
  TrackingConfig tracking;
  /// The global search (method, sampling, ranking, candidates).
  GlobalSearchConfig search;
  std::optional<PoseHint> hint;
  /// A hint that yields no declared pose within this many scans widens to the global search.
  int hint_scans = 10;

  // --- declaring a pose ---
  int confirm_scans = 4;       ///< consecutive good scans of the leading hypothesis
  double min_agreement = 0.8;  ///< good scan: FitnessValue::agreement at least this
  double min_known = 0.5;      ///< ... and this share of end points on known cells
  double min_travel = 0.3;     ///< metres moved (or min_turn turned) since the hypothesis began
  double min_turn_deg = 30.0;
  /// Runner-up's mean evidence / the leader's must stay below this, in (0, 1] (or the
  /// contradiction route clears the rival).
  double max_ambiguity = 0.75;
  int max_hypotheses = 20;  ///< pool size
  int research_every = 5;   ///< scans with no well-matching hypothesis between global searches
  /// Each global search after which still no hypothesis matches well doubles the wait before
  /// the next, up to this many scans (>= research_every); a well-matching hypothesis resets it
  /// to research_every. = research_every: a search every research_every scans, no backoff. A
  /// follower where the map knows little stops spending a global search every second.
  int research_every_max = 20;
  /// Before declaring, search globally on the current scan once more (always kGrid, never
  /// limited by the hint); a distinct pose that explains it nearly as well (verify_ambiguity)
  /// joins the hypotheses and the declaration waits.
  bool verify = true;
  /// The final check's rival: a pose whose evidence on this scan is at least this share of the
  /// leader's, in (0, 1]. One scan is noisier than max_ambiguity's mean over several, so the
  /// bar is higher.
  double verify_ambiguity = 0.85;
  /// Before declaring, probe +-0.5 m / +-3 deg around the leader: a pose that explains the scan
  /// clearly better (evidence) takes the hypothesis over, which must then confirm again.
  bool local_check = true;
  /// The contradiction route (0 = off: evidence ratio only): a hypothesis is also
  /// clear of a rival whose mean share of end points on known free cells is at least this
  /// factor times its own plus contradiction_margin, if its own mean agreement and known share
  /// reach the minima below and it matched well on contradiction_min_streak scans in a row; the
  /// final check then counts a fresh pose as a rival only if it is not clear of it in the same
  /// way. Where the map knows a place partly, end points in unknown cells cost the true pose
  /// evidence; a look-alike place fully known puts many of its end points on free cells.
  double contradiction_factor = 2.0;
  double contradiction_margin = 0.1;
  double contradiction_min_agreement = 0.85;
  double contradiction_min_known = 0.65;
  int contradiction_min_streak = 10;
  int hypothesis_iterations = 300;  ///< ES iterations per scan for each hypothesis (localising)
  double prune_ratio = 0.7;  ///< hypotheses below this share of the best mean evidence drop out

  // --- tracking ---
  double lost_agreement = 0.6;  ///< a scan matching worse than this (or lost_known) is bad
  double lost_known = 0.3;
  int lost_scans = 5;  ///< consecutive bad scans to declare the robot lost
  /// The tracking's hold along the motion (TrackingConfig::motion_hold), which the localiser
  /// sets in its copy of `tracking` (the SLAM's stays off): a follower's map is fixed while it
  /// tracks, and along a corridor a few centimetres too far per scan carry on through the
  /// constant-velocity prediction until the next turn finds the pose wrong.
  double motion_hold = 0.02;

  std::uint64_t seed = 1;
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// What happened to one scan.
struct LocaliserStep {
  LocaliserState state = LocaliserState::kWaitingForMap;
  bool declared = false;  ///< the pose was declared at this scan (state became kTracking)
  bool lost = false;      ///< tracking was lost at this scan
  Pose2 pose;             ///< tracking: the pose; localising: the leading hypothesis (if any)
  FitnessValue value;     ///< fitness terms at `pose`
  float score = 0.0f;     ///< evidence() at `pose` (0..1)
  std::size_t hypotheses = 0;
  bool global_search = false;  ///< a global search ran for this scan
  double cpu_ms = 0.0;         ///< thread CPU time spent on this scan
};

/// A hypothesis followed while localising, as diagnostics see it.
struct HypothesisView {
  std::uint32_t id = 0;  ///< distinct per hypothesis since the localiser was built
  Pose2 pose;
  float score = 0.0f;  ///< mean evidence() over the last confirm_scans scans
  int good_streak = 0;
  double travel = 0.0;
  FitnessValue value;  ///< at the last scan
};

/// Receives a Localiser's diagnostics (logs, the benchmark's traces); every hook defaults to
/// nothing. Called on the thread running Localiser::process, during the call.
class LocaliserObserver {
 public:
  virtual ~LocaliserObserver() = default;
  /// Whether to record the stages of each global search for on_search_stages (they hold every
  /// sample position of a grid search: diagnostics only).
  virtual bool wants_search_stages() const { return false; }
  /// After each global search, if wants_search_stages(): its stages (empty for an ES search).
  virtual void on_search_stages(const SearchStages& /*stages*/) {}
  /// At the end of every process(): the step and the hypotheses followed (none once tracking).
  virtual void on_scan(const LocaliserStep& /*step*/,
                       const std::vector<HypothesisView>& /*hypotheses*/) {}
};

class Localiser {
 public:
  explicit Localiser(LocaliserConfig config);

  /// Processes one scan against `map` (read only during the call).
  LocaliserStep process(const GridMap& map, const LaserScan& scan);

  LocaliserState state() const { return state_; }
  const LocaliserConfig& config() const { return config_; }
  /// Forget everything and search globally again (e.g. a new map epoch).
  void reset();
  /// Forget everything and search around `hint` (as AMCL does on /initialpose): for the next
  /// hint_scans scans, then globally. Throws std::invalid_argument for a bad radius or angle.
  void set_hint(const PoseHint& hint);
  /// Diagnostics go to `observer` (nullptr: none; the default). It must outlive its use here.
  /// Observing changes nothing the localiser computes or draws.
  void set_observer(LocaliserObserver* observer) { observer_ = observer; }

 private:
  struct Hypothesis {
    std::uint32_t id = 0;
    MotionState motion;
    Pose2 origin;         ///< where it began (motion check)
    double travel = 0.0;  ///< metres along its path
    double turn = 0.0;    ///< radians turned in all
    int good_streak = 0;
    int scans = 0;
    float score = 0.0f;  ///< mean evidence() over the last confirm_scans scans
    /// Means over the same scans: end points on known free cells / all, agreement, known.
    float contradiction = 0.0f, agreement = 0.0f, known = 0.0f;
    std::vector<FitnessValue> recent;  ///< the last confirm_scans scans' fitness terms
    FitnessValue value;
  };

  /// The global search's candidates (use_hint: around config_.hint, if any), reporting its
  /// stages to the observer.
  std::vector<Pose2> search_globally(const GridMap& map, const ScanPoints& points, bool use_hint,
                                     GlobalSearchMethod how);
  void add_hypotheses(const std::vector<Pose2>& poses, const GridMap& map, const ScanPoints& points,
                      const LaserScan& scan);
  void score_scan(Hypothesis& h, const FitnessValue& v, const Pose2& before, const Pose2& now);
  bool good(const FitnessValue& v) const;
  /// Whether `h` is clear of `rival` (max_ambiguity on evidence, or the contradiction route).
  bool clear_of(const Hypothesis& h, const Hypothesis& rival) const;
  bool contradiction_route(const Hypothesis& h) const;
  /// A rival's contradiction share is at least factor x `own` + margin.
  bool contradicted(float rival, float own) const;
  /// The full-resolution evaluator hypotheses are scored with (the SLAM's fitness options).
  FitnessEvaluator fine_evaluator(const GridMap& map, const ScanPoints& points) const;
  /// One scan while localising: follow the hypotheses, search if due, declare the leader if
  /// the rules allow (declared: state kTracking).
  void localise(const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                LocaliserStep& step);
  /// Tracks every hypothesis one scan on, then merges those that converged onto one pose and
  /// drops the clearly worse (prune_ratio, max_hypotheses).
  void follow_hypotheses(const GridMap& map, const ScanPoints& points, const LaserScan& scan);
  /// Searches globally when nothing is followed, or nothing matched well for research_wait_
  /// scans (which then doubles, up to research_every_max); sets step.global_search.
  void search_if_due(const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                     LocaliserStep& step);
  /// Hypothesis i may be declared: confirm_scans good scans, moved, clear of every other.
  bool ready(std::size_t i) const;
  /// The hypothesis to report (best score, or another one the contradiction route makes
  /// ready) and whether it may be declared. The pool must not be empty.
  std::pair<std::size_t, bool> leader() const;
  /// The local check before declaring: true when a clearly better pose nearby took the
  /// leader over (it must confirm again).
  bool moved_by_local_check(const FitnessEvaluator& fine, std::size_t lead, LocaliserStep& step);
  /// The final check before declaring: true when a fresh global search finds no rival of the
  /// leader; rivals join the pool.
  bool verified(const GridMap& map, const ScanPoints& points, const LaserScan& scan,
                std::size_t lead, const FitnessEvaluator& fine, LocaliserStep& step);
  void track(const GridMap& map, const ScanPoints& points, const LaserScan& scan,
             LocaliserStep& step);
  std::vector<HypothesisView> hypothesis_views() const;

  LocaliserConfig config_;
  EvolutionStrategy es_;
  EvolutionStrategy hypothesis_es_;
  GlobalSearch search_;
  Rng rng_;
  LocaliserState state_ = LocaliserState::kWaitingForMap;
  std::vector<Hypothesis> pool_;
  int scans_since_search_ = 0;
  int research_wait_ = 0;    ///< scans to the next global search while none matches well
  int searching_scans_ = 0;  ///< scans since localising (re)started
  Hypothesis tracked_;
  int bad_streak_ = 0;
  LocaliserObserver* observer_ = nullptr;
  std::uint32_t next_id_ = 0;
};

}  // namespace esfleet
