#include "esfleet/core/fitness.hpp"

#include <gtest/gtest.h>

#include <numbers>

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

}  // namespace
}  // namespace esfleet
