// Pose graph optimisation on hand-made graphs with known answers.

#include "esfleet/core/pose_graph.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace esfleet {
namespace {

constexpr double kQuarter = std::numbers::pi / 2;

PoseGraphEdge edge(std::size_t from, std::size_t to, Pose2 z, double sigma_xy = 0.01,
                   double sigma_theta = 0.01, double huber = 0.0) {
  return {from, to, z, 1.0 / (sigma_xy * sigma_xy), 1.0 / (sigma_theta * sigma_theta), huber};
}

/// A 4 m square driven counter-clockwise: nodes at the corners (heading along the next side),
/// odometry edges whose heading drifts 3 degrees per side, and one loop edge saying the last
/// corner is the first one.
PoseGraph drifting_square(double loop_huber = 0.0) {
  PoseGraph g;
  const Pose2 side{4.0, 0.0, kQuarter + deg_to_rad(3.0)};  // drift in each measured turn
  Pose2 p{};
  g.add_node(p);
  for (int i = 1; i <= 4; ++i) {
    p = p.compose(side);
    g.add_node(p);
    g.add_edge(edge(static_cast<std::size_t>(i - 1), static_cast<std::size_t>(i), side, 0.05,
                    deg_to_rad(5.0)));
  }
  g.add_edge(edge(0, 4, Pose2{0, 0, 2 * std::numbers::pi}, 0.01, deg_to_rad(0.5), loop_huber));
  return g;
}

TEST(PoseGraph, ConsistentGraphHasZeroCostAndDoesNotMove) {
  PoseGraph g;
  g.add_node({0, 0, 0});
  g.add_node({1, 0, kQuarter});
  g.add_edge(edge(0, 1, {1, 0, kQuarter}));
  const PoseGraphResult r = g.optimize();
  EXPECT_NEAR(r.final_cost, 0.0, 1e-12);
  EXPECT_NEAR(g.node(1).x, 1.0, 1e-9);
  EXPECT_NEAR(g.node(1).theta, kQuarter, 1e-9);
}

TEST(PoseGraph, RecoversFromABadInitialGuessAndKeepsNodeZeroFixed) {
  PoseGraph g;
  g.add_node({0, 0, 0});
  g.add_node({0.5, 0.4, 0.3});  // far from the edge's claim
  g.add_node({0, 0, 0});
  g.add_edge(edge(0, 1, {1, 0, kQuarter}));
  g.add_edge(edge(1, 2, {1, 0, kQuarter}));
  const PoseGraphResult r = g.optimize(20);
  EXPECT_TRUE(r.converged);
  EXPECT_NEAR(g.node(0).x, 0.0, 1e-12);
  EXPECT_NEAR(g.node(0).y, 0.0, 1e-12);
  EXPECT_NEAR(g.node(0).theta, 0.0, 1e-12);
  EXPECT_NEAR(g.node(1).x, 1.0, 1e-6);
  EXPECT_NEAR(g.node(1).y, 0.0, 1e-6);
  EXPECT_NEAR(g.node(2).x, 1.0, 1e-6);  // (1,0) then 1 m along +y
  EXPECT_NEAR(g.node(2).y, 1.0, 1e-6);
  EXPECT_NEAR(normalize_angle(g.node(2).theta - std::numbers::pi), 0.0, 1e-6);
}

TEST(PoseGraph, LoopEdgeClosesADriftingSquare) {
  PoseGraph g = drifting_square();
  const double before = std::hypot(g.node(4).x, g.node(4).y);
  EXPECT_GT(before, 0.5);  // 12 degrees of heading drift opens the square
  const PoseGraphResult r = g.optimize(20);
  EXPECT_LT(r.final_cost, r.initial_cost);
  const double after = std::hypot(g.node(4).x, g.node(4).y);
  EXPECT_LT(after, 0.05);
  EXPECT_NEAR(normalize_angle(g.node(4).theta), 0.0, deg_to_rad(1.0));
  // The correction is spread over the sides: every corner is close to the true square.
  EXPECT_NEAR(g.node(2).x, 4.0, 0.3);
  EXPECT_NEAR(g.node(2).y, 4.0, 0.3);
}

TEST(PoseGraph, HuberKernelLimitsAWrongLoopEdge) {
  // A loop edge that is 3 m wrong: with a Huber kernel it bends the square much less.
  auto wrong = [](double huber) {
    PoseGraph g;
    Pose2 p{};
    g.add_node(p);
    const Pose2 side{4.0, 0.0, kQuarter};
    for (int i = 1; i <= 4; ++i) {
      p = p.compose(side);
      g.add_node(p);
      g.add_edge(edge(static_cast<std::size_t>(i - 1), static_cast<std::size_t>(i), side, 0.02,
                      deg_to_rad(0.5)));
    }
    g.add_edge(edge(0, 4, Pose2{3.0, 0, 0}, 0.05, deg_to_rad(1.0), huber));
    g.optimize(30);
    return std::hypot(g.node(4).x, g.node(4).y);  // the truth is 0
  };
  const double plain = wrong(0.0);
  const double robust = wrong(2.0);
  EXPECT_GT(plain, 1.0);
  EXPECT_LT(robust, plain / 2);
}

TEST(PoseGraph, EdgeChi2AndCostAgree) {
  PoseGraph g = drifting_square();
  double sum = 0;
  for (const PoseGraphEdge& e : g.edges()) sum += g.edge_chi2(e);
  EXPECT_NEAR(sum, g.cost(), 1e-9 * std::max(1.0, sum));
  EXPECT_GT(g.cost(), 0.0);
}

TEST(PoseGraph, APrefixIsTheGraphAsItWasBeforeItGrew) {
  PoseGraph g;
  g.add_node({});
  g.add_node({1.0, 0.0, 0.0});
  g.add_edge(edge(0, 1, {1.0, 0.0, 0.0}));
  const PoseGraph before = g;
  g.add_node({2.0, 0.1, 0.05});
  g.add_edge(edge(1, 2, {1.0, 0.0, 0.0}));
  g.add_edge(edge(0, 2, {2.0, 0.0, 0.0}));
  const PoseGraph p = g.prefix(2, 1);
  EXPECT_EQ(p.nodes(), before.nodes());
  ASSERT_EQ(p.edges().size(), 1u);
  EXPECT_EQ(p.edges()[0].to, 1u);
  EXPECT_EQ(p.edges()[0].measurement, before.edges()[0].measurement);
  EXPECT_EQ(p.cost(), before.cost());
  EXPECT_EQ(g.prefix(3, 3).cost(), g.cost());
  EXPECT_THROW((void)g.prefix(4, 3), std::out_of_range);  // more than it has
  EXPECT_THROW((void)g.prefix(3, 4), std::out_of_range);
  EXPECT_THROW((void)g.prefix(2, 2), std::out_of_range);  // edge 1 -> 2 without node 2
}

TEST(PoseGraph, EdgeToAMissingNodeIsRefused) {
  PoseGraph g;
  g.add_node({});
  EXPECT_THROW(g.add_edge(edge(0, 1, {})), std::out_of_range);
}

}  // namespace
}  // namespace esfleet
