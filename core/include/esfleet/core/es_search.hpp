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

#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
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
  Pose2 pose;                          ///< centre (+) best correction
  Correction best;                     ///< the best correction
  FitnessValue value;                  ///< full fitness terms at the best pose
  int replacements = 0;                ///< children that entered the population
  int evaluations = 0;                 ///< fitness evaluations made (mu + T)
  std::vector<Correction> population;  ///< the final population (e.g. to refine further)
};

/// The zero correction, then `extra` (e.g. other motion hypotheses), then normal draws
/// N(0, sigma_xy) / N(0, sigma_theta) up to `mu` individuals.
std::vector<Correction> make_initial_population(int mu, double sigma_xy, double sigma_theta,
                                                Rng& rng,
                                                const std::vector<Correction>& extra = {});

/// Deterministic local polish (ours, beyond the paper): compass/pattern search from `start`,
/// steps +-step_xy on x and y and +-step_theta on theta; a step that improves the fitness is
/// taken, otherwise the steps halve, until step_xy < min_step_xy. Returns the best pose found
/// (never worse than `start`) and its fitness terms; `evaluations` counts the calls.
/// With any fitness callable float(const Pose2&); `value` then holds only the fitness.
template <typename F>
EsResult refine_pose_with(F&& fitness, const Pose2& start, double step_xy, double step_theta,
                          double min_step_xy);
inline EsResult refine_pose(const FitnessEvaluator& fitness, const Pose2& start, double step_xy,
                            double step_theta, double min_step_xy) {
  EsResult r = refine_pose_with([&](const Pose2& p) { return fitness.fitness(p); }, start, step_xy,
                                step_theta, min_step_xy);
  r.value = fitness.evaluate(r.pose);
  return r;
}

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

  /// The ES with any fitness callable float(const Pose2&) (inlined: the hot loop).
  template <typename F>
  EsResult search_with(F&& fitness, const Pose2& centre, const std::vector<Correction>& initial,
                       Rng& rng, int iterations = -1) const;

 private:
  EsConfig config_;
};

// ---- implementation of the templates ----

template <typename F>
EsResult EvolutionStrategy::search_with(F&& fitness, const Pose2& centre,
                                        const std::vector<Correction>& initial, Rng& rng,
                                        int iterations) const {
  if (iterations < 0) iterations = config_.iterations;
  const auto mu = static_cast<std::size_t>(config_.mu);
  if (initial.size() != mu) {
    throw std::invalid_argument("initial population has " + std::to_string(initial.size()) +
                                " individuals, es.mu is " + std::to_string(mu));
  }
  std::vector<Correction> pop = initial;
  std::vector<float> fit(mu);
  for (std::size_t k = 0; k < mu; ++k) fit[k] = fitness(apply_correction(centre, pop[k]));

  auto best_index = [&] {
    std::size_t b = 0;
    for (std::size_t k = 1; k < mu; ++k)
      if (fit[k] > fit[b]) b = k;
    return b;
  };
  auto worst_index = [&] {
    std::size_t w = 0;
    for (std::size_t k = 1; k < mu; ++k)
      if (fit[k] < fit[w]) w = k;
    return w;
  };
  std::size_t best = best_index();
  std::size_t worst = worst_index();

  const double ax = config_.alpha_xy * 0.01, bx = config_.beta * 0.01;               // cm -> m
  const double at = deg_to_rad(config_.alpha_theta), bt = deg_to_rad(config_.beta);  // deg -> rad
  EsResult result;
  for (int it = 0; it < iterations; ++it) {
    const std::size_t k = rng.below(static_cast<std::uint32_t>(mu));
    const Correction& a = pop[k];
    const Correction& b = pop[best];
    const std::uint64_t bits = rng.next_u64();
    Correction child{(bits & 1) ? a.dx : b.dx, (bits & 2) ? a.dy : b.dy,
                     (bits & 4) ? a.dtheta : b.dtheta};
    const float f_max = fit[best], f_min = fit[worst];
    const double ratio =
        f_max > f_min ? static_cast<double>(f_max - fit[k]) / static_cast<double>(f_max - f_min)
                      : 0.0;
    child.dx += (ax * ratio + bx) * rng.normal();
    child.dy += (ax * ratio + bx) * rng.normal();
    child.dtheta += (at * ratio + bt) * rng.normal();
    const float f = fitness(apply_correction(centre, child));
    if (f > fit[worst]) {
      pop[worst] = child;
      fit[worst] = f;
      ++result.replacements;
      if (f > fit[best]) best = worst;
      worst = worst_index();
    }
  }
  result.best = pop[best];
  result.pose = apply_correction(centre, result.best);
  result.evaluations = config_.mu + iterations;
  result.value.fitness = fit[best];
  result.population = std::move(pop);
  return result;
}

template <typename F>
EsResult refine_pose_with(F&& fitness, const Pose2& start, double step_xy, double step_theta,
                          double min_step_xy) {
  EsResult r;
  Pose2 best = start;
  float f_best = fitness(best);
  r.evaluations = 1;
  while (step_xy >= min_step_xy) {
    bool improved = false;
    const Pose2 moves[6] = {{step_xy, 0, 0},  {-step_xy, 0, 0},   {0, step_xy, 0},
                            {0, -step_xy, 0}, {0, 0, step_theta}, {0, 0, -step_theta}};
    for (const Pose2& m : moves) {
      const Pose2 p{best.x + m.x, best.y + m.y, normalize_angle(best.theta + m.theta)};
      const float f = fitness(p);
      ++r.evaluations;
      if (f > f_best) {
        f_best = f;
        best = p;
        improved = true;
      }
    }
    if (!improved) {
      step_xy *= 0.5;
      step_theta *= 0.5;
    }
  }
  r.pose = best;
  r.value.fitness = f_best;
  return r;
}

}  // namespace esfleet
