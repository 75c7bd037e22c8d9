#pragma once
// The localiser's global search (ours, after the paper's; docs/localisation.md has the
// measurements): candidate poses for one scan over the known free space of a map and all
// headings, or within a box around a pose hint. No prior knowledge is needed.
//
//  - GlobalSearchMethod::kGrid (default): every sample position (a grid over free cells) and
//    heading is scored on a coarse pyramid level (CoarseScore); the best distinct ones are
//    re-ranked by evidence on a finer level, and the best of those refined with the (mu+1)-ES
//    at full resolution.
//  - GlobalSearchMethod::kEs (the paper's way): the ES itself, its initial population spread
//    uniformly over free space and headings, restarted `es_restarts` times.

#include <cstdint>
#include <vector>

#include "esfleet/core/es_search.hpp"
#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/grid_map.hpp"
#include "esfleet/core/random.hpp"
#include "esfleet/core/scan_points.hpp"
#include "esfleet/core/tracking.hpp"

namespace esfleet {

enum class GlobalSearchMethod : std::uint8_t {
  kGrid,  ///< coarse exhaustive scoring, then ES refinement of the best (ours, default)
  kEs,    ///< the ES alone from a population spread over free space, with restarts (paper)
};

/// The grid search's coarse ranking (pyramid level `coarse_level`, each cell the maximum of
/// the cells it covers).
enum class CoarseScore : std::uint8_t {
  /// The paper's fitness p_occ * sum of map values (Condition 1). On the blurred level a cell
  /// counts against p_occ unless one of the cells it covers was only ever hit, so p_occ
  /// rewards end points near rarely observed cells, and a well-observed corridor whose walls
  /// grazing beams also cross ranks low (docs/localisation.md, "Why these defaults").
  kFitness,
  /// The sum of map values alone (Condition 2; ours, the default).
  kSum,
  /// Both: the `coarse_keep` best distinct poses by the fitness, then as many by the sum.
  kBoth,
};

/// A pose guess: search within `radius` metres and `angle_deg` degrees of it.
struct PoseHint {
  Pose2 pose;
  double radius = 1.0;
  double angle_deg = 30.0;
};

struct GlobalSearchConfig {
  GlobalSearchMethod method = GlobalSearchMethod::kGrid;
  int coarse_level = 3;         ///< pyramid level scored exhaustively (kGrid)
  double step_xy = 0.0;         ///< sample grid, metres; 0 = 3/4 of a coarse cell (0.3 m)
  double step_theta_deg = 0.0;  ///< heading step; 0 = a coarse cell at the median range, <= 5 deg
  int coarse_points = 60;       ///< end points used for coarse scoring (evenly strided)
  /// How the grid search ranks its coarse poses (see CoarseScore).
  CoarseScore coarse_score = CoarseScore::kSum;
  double free_max_value = 0.25;  ///< a sample cell is free when known and hit/(hit+err) <= this
  int coarse_keep = 300;         ///< distinct coarse poses re-ranked on mid_level
  int mid_level = 1;             ///< pyramid level of the re-ranking (evidence over a small window)
  int candidates = 10;           ///< distinct candidates refined by the ES and returned
  double distinct_xy = 0.5;      ///< candidates closer than this (and distinct_theta) are one
  double distinct_theta_deg = 10.0;
  int es_restarts = 20;      ///< kEs: independent ES runs per global search
  int es_iterations = 3000;  ///< kEs: iterations per run (the population is the ES's mu)

  /// Throws std::invalid_argument naming the field (as "localise.<field>", the flags' section).
  void validate() const;
};

/// The stages of one grid search (diagnostics): the distinct coarse poses kept, the same
/// re-ranked at mid_level (best first, with their evidence) and the candidates refined (before
/// the ES, with their evidence). The ES search (GlobalSearchMethod::kEs) leaves them empty.
struct SearchStages {
  /// Every sample position with its best heading and coarse score (before ranking).
  std::vector<Pose2> samples;
  std::vector<float> sample_score;
  /// The coarse scoring's options (GlobalSearch::coarse_options): an evaluator's fitness with
  /// them is the score the sample positions were ranked and recorded by.
  FitnessOptions coarse_options;
  std::vector<Pose2> coarse;
  std::vector<Pose2> ranked;
  std::vector<float> ranked_evidence;
  std::vector<Pose2> candidates;
  std::vector<float> candidate_evidence;
};

class GlobalSearch {
 public:
  /// `tracking` gives the ES that refines the candidates and the fitness options (penalty,
  /// interpolation), as the per-scan tracking step uses them. Throws std::invalid_argument
  /// naming the field when `config` is invalid.
  GlobalSearch(GlobalSearchConfig config, const TrackingConfig& tracking);

  /// Candidate poses for `points` in `map`, by `method` (the verification before declaring
  /// asks for kGrid whatever the configured method): at most `candidates`, pairwise distinct
  /// (distinct_xy, distinct_theta_deg), best first; with `hint` only positions within its
  /// radius (plus a sample step) and headings within its angle. None when the map has no free
  /// cell to sample. Draws from `rng` (the ES refinement, the ES search). `stages` (optional)
  /// receives this search's stages.
  std::vector<Pose2> run(const GridMap& map, const ScanPoints& points, const PoseHint* hint,
                         GlobalSearchMethod method, Rng& rng, SearchStages* stages = nullptr) const;

  /// The grid search's coarse scoring for `points` in `map`: level, strided end points and,
  /// unless ranking by CoarseScore::kSum, the penalty.
  FitnessOptions coarse_options(const GridMap& map, const ScanPoints& points) const;

  const GlobalSearchConfig& config() const { return config_; }

 private:
  std::vector<Pose2> grid_candidates(const GridMap& map, const ScanPoints& points,
                                     const std::vector<Pose2>& samples, double step_xy,
                                     double step_theta, double theta0, double theta_span, Rng& rng,
                                     SearchStages* stages) const;
  std::vector<Pose2> es_candidates(const GridMap& map, const ScanPoints& points,
                                   const std::vector<Pose2>& samples, double theta0,
                                   double theta_span, Rng& rng) const;

  GlobalSearchConfig config_;
  TrackingConfig tracking_;
  EvolutionStrategy es_;
};

}  // namespace esfleet
