#pragma once
// (mu+1)-Evolution Strategy pose search (Toda & Kubota; paper Sec. 2.2, Eq. 9).
//
// An individual is a correction g = (dx, dy, dtheta) to a centre pose (the pose predicted for
// this scan); its fitness is FitnessEvaluator's value of centre (+) g, applied as
// (x + dx, y + dy, theta + dtheta). The population keeps mu individuals. Each of the T
// iterations makes exactly ONE child:
//   1. elitist crossover: pick one individual k uniformly at random; each gene of the child is
//      taken from k or from the best individual with probability 1/2 (uniform crossover; the
//      paper says only "combining genetic information");
//   2. adaptive mutation (Eq. 9): g_h += (alpha_h * (f_max - f_k) / (f_max - f_min) + beta_h)
//      * N(0, 1), with f_k the fitness of the picked individual and f_max / f_min the
//      population's best / worst; when f_max == f_min only the beta term is used;
//   3. the child replaces the worst individual if it is strictly better (ours: the paper says
//      only "an existing solution is replaced").
// Units (the paper gives none): alpha_1, alpha_2 and beta for x, y in centimetres, alpha_3 and
// beta for theta in degrees; with these the paper's numbers (10, 10, 1, 0.01) work on both logs.
// The initial population is the caller's choice (make_initial_population for the usual one).
// Randomness comes only from the Rng passed in, so a seed fixes the result.

#include <functional>
#include <vector>

#include "esfleet/core/fitness.hpp"
#include "esfleet/core/geometry.hpp"
#include "esfleet/core/random.hpp"

namespace esfleet {

struct EsConfig {
  int mu = 100;              ///< parents (paper Table 2)
  int iterations = 1000;     ///< T: children per search, one per iteration (paper Table 2)
  double alpha_xy = 10.0;    ///< alpha_1 = alpha_2, centimetres (paper Table 2)
  double alpha_theta = 1.0;  ///< alpha_3, degrees (paper Table 2)
  double beta = 0.01;        ///< beta_h: centimetres for x, y; degrees for theta (paper Table 2)
  /// Throws std::invalid_argument naming the field.
  void validate() const;
};

/// A correction to the centre pose: metres, metres, radians.
struct Correction {
  double dx = 0.0;
  double dy = 0.0;
  double dtheta = 0.0;
};

inline Pose2 apply_correction(const Pose2& centre, const Correction& g) {
  return {centre.x + g.dx, centre.y + g.dy, normalize_angle(centre.theta + g.dtheta)};
}

struct EsResult {
  Pose2 pose;          ///< centre (+) best correction
  Correction best;     ///< the best correction
  FitnessValue value;  ///< full fitness terms at the best pose
  int replacements = 0;  ///< children that entered the population
  int evaluations = 0;   ///< fitness evaluations made (mu + T)
  std::vector<Correction> population;  ///< the final population (e.g. to refine further)
};

/// The zero correction, then `extra` (e.g. other motion hypotheses), then normal draws
/// N(0, sigma_xy) / N(0, sigma_theta) up to `mu` individuals.
std::vector<Correction> make_initial_population(int mu, double sigma_xy, double sigma_theta,
                                                Rng& rng,
                                                const std::vector<Correction>& extra = {});

/// Any fitness function of a pose (the evaluator's, or a test's).
using PoseFitness = std::function<float(const Pose2&)>;

class EvolutionStrategy {
 public:
  explicit EvolutionStrategy(EsConfig config = {});
  const EsConfig& config() const { return config_; }

  /// Runs `iterations` iterations (< 0: the configured T) from `initial` (must hold exactly mu
  /// individuals).
  EsResult search(const FitnessEvaluator& fitness, const Pose2& centre,
                  const std::vector<Correction>& initial, Rng& rng, int iterations = -1) const;
  /// Same with a generic fitness (slower: std::function per call); `value` holds only fitness.
  EsResult search(const PoseFitness& fitness, const Pose2& centre,
                  const std::vector<Correction>& initial, Rng& rng, int iterations = -1) const;

 private:
  template <typename F>
  EsResult run(F&& fitness, const Pose2& centre, const std::vector<Correction>& initial,
               Rng& rng, int iterations) const;
  EsConfig config_;
};

}  // namespace esfleet
