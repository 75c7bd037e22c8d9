#include "esfleet/core/fitness.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>

#include "esfleet/core/map_update.hpp"
#include "esfleet/core/random.hpp"
#include "synthetic_world.hpp"

namespace esfleet {
namespace {

// A hand-made map with 1 m cells:
//   (5,0): hit 3, err 1 -> 0.75, counts in both penalty sums
//   (5,1): hit 0, err 2 -> 0,    counts as err' only
//   (5,2): unknown      -> 0,    counts in neither sum
//   (5,3): hit 1, err 0 -> 1,    counts as hit' only
GridMap hand_made_map() {
  GridMap map(GridMapConfig{.cell_size = 1.0, .tile_edge = 8});
  for (int i = 0; i < 3; ++i) map.add_hit({5, 0});
  map.add_err({5, 0});
  map.add_err({5, 1});
  map.add_err({5, 1});
  map.add_hit({5, 3});
  return map;
}

ScanPoints points_at(std::vector<std::pair<float, float>> xy) {
  ScanPoints p;
  for (auto [x, y] : xy) {
    p.x.push_back(x);
    p.y.push_back(y);
    p.range.push_back(std::hypot(x, y));
  }
  return p;
}

TEST(FitnessTest, ConditionOneMultipliesSumByPenalty) {
  const GridMap map = hand_made_map();
  const ScanPoints pts = points_at({{5.5f, 0.5f}, {5.5f, 1.5f}, {5.5f, 2.5f}, {5.5f, 3.5f}});
  const FitnessValue v = FitnessEvaluator(map, pts, true).evaluate(Pose2{});
  EXPECT_FLOAT_EQ(v.sum_map, 1.75f);
  EXPECT_EQ(v.n_hit, 2);
  EXPECT_EQ(v.n_err, 2);
  EXPECT_EQ(v.n_points, 4);
  EXPECT_FLOAT_EQ(v.p_occ, 0.5f);
  EXPECT_FLOAT_EQ(v.fitness, 0.875f);
}

TEST(FitnessTest, ConditionTwoIsTheBareSum) {
  const GridMap map = hand_made_map();
  const ScanPoints pts = points_at({{5.5f, 0.5f}, {5.5f, 1.5f}, {5.5f, 2.5f}, {5.5f, 3.5f}});
  EXPECT_FLOAT_EQ(FitnessEvaluator(map, pts, false).fitness(Pose2{}), 1.75f);
}

TEST(FitnessTest, PoseMovesThePoints) {
  const GridMap map = hand_made_map();
  // One point 3.5 m ahead; from (5.5, -3.0) facing +y it lands in (5, 0).
  const ScanPoints pts = points_at({{3.5f, 0.0f}});
  const FitnessEvaluator eval(map, pts, true);
  const FitnessValue v = eval.evaluate(Pose2{5.5, -3.0, std::numbers::pi / 2});
  EXPECT_FLOAT_EQ(v.sum_map, 0.75f);
  EXPECT_FLOAT_EQ(v.p_occ, 0.5f);
  // Facing -y it lands in unknown space: no sums, p_occ defined as 0.
  const FitnessValue u = eval.evaluate(Pose2{5.5, -3.0, -std::numbers::pi / 2});
  EXPECT_EQ(u.n_hit + u.n_err, 0);
  EXPECT_EQ(u.p_occ, 0.0f);
  EXPECT_EQ(u.fitness, 0.0f);
}

TEST(FitnessTest, AllPointsOnFreeCellsScoreZero) {
  const GridMap map = hand_made_map();
  const ScanPoints pts = points_at({{5.5f, 1.5f}, {5.2f, 1.9f}});
  const FitnessValue v = FitnessEvaluator(map, pts, true).evaluate(Pose2{});
  EXPECT_EQ(v.n_err, 2);
  EXPECT_EQ(v.n_hit, 0);
  EXPECT_EQ(v.fitness, 0.0f);
}

TEST(FitnessTest, NonFiniteOrFarPoseScoresZero) {
  const GridMap map = hand_made_map();
  const ScanPoints pts = points_at({{5.5f, 0.5f}});
  const FitnessEvaluator eval(map, pts, true);
  EXPECT_EQ(eval.fitness(Pose2{std::nan(""), 0.0, 0.0}), 0.0f);
  EXPECT_EQ(eval.fitness(Pose2{1e12, 0.0, 0.0}), 0.0f);
  EXPECT_EQ(eval.fitness(Pose2{0.0, 0.0, INFINITY}), 0.0f);
}

/// Bit-for-bit equal fitness terms (a float compared by its bits, so -0 and 0 differ).
void expect_same(const FitnessValue& a, const FitnessValue& b, const std::string& what) {
  EXPECT_EQ(std::bit_cast<std::uint32_t>(a.fitness), std::bit_cast<std::uint32_t>(b.fitness))
      << what << ": fitness " << a.fitness << " vs " << b.fitness;
  EXPECT_EQ(std::bit_cast<std::uint32_t>(a.sum_map), std::bit_cast<std::uint32_t>(b.sum_map))
      << what << ": sum " << a.sum_map << " vs " << b.sum_map;
  EXPECT_EQ(std::bit_cast<std::uint32_t>(a.p_occ), std::bit_cast<std::uint32_t>(b.p_occ)) << what;
  EXPECT_EQ(a.n_hit, b.n_hit) << what;
  EXPECT_EQ(a.n_err, b.n_err) << what;
  EXPECT_EQ(a.n_known, b.n_known) << what;
  EXPECT_EQ(a.n_points, b.n_points) << what;
}

TEST(HeadingScorer, ScoresBitForBitAsTheEvaluatorOnEveryLevel) {
  // A map of a room from ray-cast scans, with its pyramid; a scan from inside it.
  const auto world = testing::asymmetric_room();
  GridMapConfig mc;
  mc.pyramid_levels = 3;
  GridMap map(mc);
  for (double x = 0.5; x < 12.0; x += 1.5) {
    for (double y = 0.5; y < 8.0; y += 1.5) {
      const Pose2 p{x, y, 0.3 * x};
      update_map(map, prepare_scan(testing::make_scan(world, p)), p, MapUpdateConfig{});
    }
  }
  const ScanPoints points = prepare_scan(testing::make_scan(world, {4.0, 3.0, 0.4}));
  Rng rng(11);
  int scored = 0;  // evaluations with end points on occupied cells (the comparison has teeth)
  for (int level = 0; level <= 3; ++level) {
    for (const int stride : {1, 7}) {
      for (const bool penalty : {true, false}) {
        const FitnessOptions o{.use_penalty = penalty, .level = level, .stride = stride};
        const FitnessEvaluator eval(map, points, o);
        HeadingScorer scorer(map, points, o);
        for (int h = 0; h < 6; ++h) {
          const double theta = normalize_angle(-3.1 + 1.17 * h);
          scorer.set_heading(theta);
          for (int k = 0; k < 300; ++k) {
            // Positions over the room and well outside it (cells beyond the tile directory).
            const double x = -8.0 + 28.0 * rng.uniform(), y = -8.0 + 24.0 * rng.uniform();
            const FitnessValue v = scorer.evaluate(x, y);
            scored += v.n_hit > 0;
            expect_same(v, eval.evaluate({x, y, theta}),
                        "level " + std::to_string(level) + " stride " + std::to_string(stride) +
                            " pose (" + std::to_string(x) + ", " + std::to_string(y) + ", " +
                            std::to_string(theta) + "), seed 11");
          }
        }
        scorer.set_heading(std::nan(""));
        expect_same(scorer.evaluate(1.0, 1.0), eval.evaluate({1.0, 1.0, std::nan("")}), "nan");
        scorer.set_heading(0.0);
        expect_same(scorer.evaluate(1e12, 0.0), eval.evaluate({1e12, 0.0, 0.0}), "far");
      }
    }
  }
  EXPECT_GT(scored, 10000);  // of 28 800
  EXPECT_THROW(HeadingScorer(map, points, FitnessOptions{.interpolate = true}),
               std::invalid_argument);
  EXPECT_THROW(HeadingScorer(map, points, FitnessOptions{.level = 4}), std::invalid_argument);
}

}  // namespace
}  // namespace esfleet
