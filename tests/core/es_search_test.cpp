#include "esfleet/core/es_search.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "esfleet/core/map_update.hpp"
#include "esfleet/core/scan_points.hpp"
#include "synthetic_world.hpp"

namespace esfleet {
namespace {

using testing::asymmetric_room;
using testing::make_scan;

// Map of the synthetic room built from scans at known poses (what the leader would have), the
// paper's way (every crossed cell cleared), as the paper's ES below expects.
GridMap room_map() {
  GridMap map;
  const auto world = asymmetric_room();
  const Pose2 poses[] = {{2, 2, 0.3},  {6, 4, 1.2},  {10, 6, -2.0}, {5.5, 7, -1.0},
                         {2, 5, -0.4}, {10, 1, 2.5}, {6, 1.5, 1.6}, {3, 7, 0.1}};
  MapUpdateConfig paper;
  paper.free_margin = 0.0;
  for (const Pose2& p : poses) update_map(map, prepare_scan(make_scan(world, p)), p, paper);
  return map;
}

double angle_diff_deg(double a, double b) { return std::abs(rad_to_deg(normalize_angle(a - b))); }

TEST(EsSearchTest, RecoversKnownOffsetOverSeededPoses) {
  const GridMap map = room_map();
  const auto world = asymmetric_room();
  const EvolutionStrategy es;  // paper defaults: mu 100, T 1000, alpha 10 cm / 1 deg, beta 0.01
  constexpr std::uint64_t kSeed = 20261122;
  Rng pose_rng(kSeed);
  int recovered = 0;
  constexpr int kCases = 20;
  for (int c = 0; c < kCases; ++c) {
    // A true pose in the free space of the room, away from the walls.
    const Pose2 truth{pose_rng.uniform(5.0, 11.0), pose_rng.uniform(1.0, 4.0),
                      pose_rng.uniform(-3.1, 3.1)};
    // The prediction is off by up to 15 cm and 4 degrees.
    const Pose2 predicted{truth.x + pose_rng.uniform(-0.15, 0.15),
                          truth.y + pose_rng.uniform(-0.15, 0.15),
                          truth.theta + deg_to_rad(pose_rng.uniform(-4.0, 4.0))};
    const ScanPoints pts = prepare_scan(make_scan(world, truth));
    const FitnessEvaluator eval(map, pts);
    Rng es_rng(kSeed + static_cast<std::uint64_t>(c));
    const auto initial = make_initial_population(100, 0.1, deg_to_rad(3.0), es_rng);
    const EsResult r = es.search(eval, predicted, initial, es_rng);
    const double err = std::hypot(r.pose.x - truth.x, r.pose.y - truth.y);
    const double err_deg = angle_diff_deg(r.pose.theta, truth.theta);
    if (err < 0.05 && err_deg < 1.0) {
      ++recovered;
    } else {
      ADD_FAILURE() << "seed " << kSeed << " case " << c << ": error " << err << " m, " << err_deg
                    << " deg";
    }
    EXPECT_GE(r.value.fitness, eval.fitness(predicted)) << "case " << c;
    EXPECT_EQ(r.evaluations, 1100);
  }
  EXPECT_EQ(recovered, kCases);
}

TEST(EsSearchTest, SameSeedSameResult) {
  const GridMap map = room_map();
  const auto world = asymmetric_room();
  const Pose2 truth{8.0, 2.5, 0.7};
  const ScanPoints pts = prepare_scan(make_scan(world, truth));
  const FitnessEvaluator eval(map, pts);
  const EvolutionStrategy es;
  auto run = [&](std::uint64_t seed) {
    Rng rng(seed);
    const auto initial = make_initial_population(100, 0.1, 0.05, rng);
    return es.search(eval, Pose2{8.1, 2.4, 0.65}, initial, rng).pose;
  };
  EXPECT_EQ(run(7), run(7));
  EXPECT_NE(run(7), run(8));
}

TEST(EsSearchTest, MutationFollowsEquationNineOnAQuadratic) {
  // A smooth bowl with its maximum at (0.3, -0.2, 0.1): the ES must climb to it from the
  // origin; this isolates the search from map discretisation.
  const PoseFitness bowl = [](const Pose2& p) {
    const double d =
        (p.x - 0.3) * (p.x - 0.3) + (p.y + 0.2) * (p.y + 0.2) + (p.theta - 0.1) * (p.theta - 0.1);
    return static_cast<float>(100.0 - d);
  };
  Rng rng(3);
  const EvolutionStrategy es;
  const auto initial = make_initial_population(100, 0.2, 0.1, rng);
  const EsResult r = es.search(bowl, Pose2{}, initial, rng);
  EXPECT_NEAR(r.pose.x, 0.3, 0.01);
  EXPECT_NEAR(r.pose.y, -0.2, 0.01);
  EXPECT_NEAR(r.pose.theta, 0.1, 0.01);
  EXPECT_GT(r.replacements, 0);
}

TEST(EsSearchTest, RejectsPopulationOfWrongSize) {
  const EvolutionStrategy es;
  Rng rng(1);
  const PoseFitness f = [](const Pose2&) { return 0.0f; };
  EXPECT_THROW(es.search(f, Pose2{}, std::vector<Correction>(99), rng), std::invalid_argument);
}

TEST(EsSearchTest, ConfigValidationNamesField) {
  EsConfig c;
  c.mu = 1;
  try {
    c.validate();
    FAIL() << "mu = 1 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("es.mu"), std::string::npos);
  }
}

}  // namespace
}  // namespace esfleet
