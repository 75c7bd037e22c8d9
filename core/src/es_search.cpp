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
  if (iterations < 0 || iterations > 10000000) fail("iterations", "must be in [0, 1e7]", iterations);
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

template <typename F>
EsResult EvolutionStrategy::run(F&& fitness, const Pose2& centre,
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

  const double ax = config_.alpha_xy * 0.01, bx = config_.beta * 0.01;       // cm -> m
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

EsResult EvolutionStrategy::search(const FitnessEvaluator& fitness, const Pose2& centre,
                                   const std::vector<Correction>& initial, Rng& rng,
                                   int iterations) const {
  EsResult r =
      run([&](const Pose2& p) { return fitness.fitness(p); }, centre, initial, rng, iterations);
  r.value = fitness.evaluate(r.pose);
  return r;
}

EsResult EvolutionStrategy::search(const PoseFitness& fitness, const Pose2& centre,
                                   const std::vector<Correction>& initial, Rng& rng,
                                   int iterations) const {
  return run([&](const Pose2& p) { return fitness(p); }, centre, initial, rng, iterations);
}

}  // namespace esfleet
