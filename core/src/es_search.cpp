#include "esfleet/core/es_search.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace esfleet {

void EsConfig::validate() const {
  auto fail = [](const std::string& field, const std::string& rule, double v) {
    // Built with append: GCC 12 gives a false -Wrestrict on chained operator+ here.
    std::string msg = "es.";
    msg.append(field).append(" ").append(rule).append(", got ").append(std::to_string(v));
    throw std::invalid_argument(msg);
  };
  if (mu < 2 || mu > 100000) fail("mu", "must be in [2, 100000]", mu);
  if (iterations < 0 || iterations > 10000000)
    fail("iterations", "must be in [0, 1e7]", iterations);
  if (!(alpha_xy >= 0.0) || !std::isfinite(alpha_xy)) fail("alpha_xy", "must be >= 0", alpha_xy);
  if (!(alpha_theta >= 0.0) || !std::isfinite(alpha_theta)) {
    fail("alpha_theta", "must be >= 0", alpha_theta);
  }
  if (!(beta >= 0.0) || !std::isfinite(beta)) fail("beta", "must be >= 0", beta);
}

std::vector<Correction> make_initial_population(int mu, double sigma_xy, double sigma_theta,
                                                Rng& rng, const std::vector<Correction>& extra) {
  std::vector<Correction> pop;
  pop.reserve(static_cast<std::size_t>(mu));
  pop.push_back({});
  for (const Correction& c : extra) {
    if (static_cast<int>(pop.size()) >= mu) break;
    pop.push_back(c);
  }
  while (static_cast<int>(pop.size()) < mu) {
    Correction c;
    c.dx = sigma_xy * rng.normal();
    c.dy = sigma_xy * rng.normal();
    c.dtheta = sigma_theta * rng.normal();
    pop.push_back(c);
  }
  return pop;
}

EvolutionStrategy::EvolutionStrategy(EsConfig config) : config_(config) { config_.validate(); }

EsResult EvolutionStrategy::search(const FitnessEvaluator& fitness, const Pose2& centre,
                                   const std::vector<Correction>& initial, Rng& rng,
                                   int iterations) const {
  EsResult r = search_with([&](const Pose2& p) { return fitness.fitness(p); }, centre, initial, rng,
                           iterations);
  r.value = fitness.evaluate(r.pose);
  return r;
}

EsResult EvolutionStrategy::search(const PoseFitness& fitness, const Pose2& centre,
                                   const std::vector<Correction>& initial, Rng& rng,
                                   int iterations) const {
  return search_with([&](const Pose2& p) { return fitness(p); }, centre, initial, rng, iterations);
}

}  // namespace esfleet
