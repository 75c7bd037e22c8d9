// Planning and motion: over many seeded ticks every true pose keeps the clearance (checked by
// brute force against the world's cells), robots reach their goals, speeds and turn rates stay
// within the limits; and the odometry model.

#include "esfleet/sim/robot.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "esfleet/sim/fleet.hpp"
#include "esfleet/sim/planner.hpp"
#include "sim_test_world.hpp"

namespace esfleet::sim {
namespace {

TEST(PlanGrid, OpenCellsKeepTheClearanceAndPathsGoThroughTheDoor) {
  const World world(testing::two_rooms());
  const PlanGrid grid(world, 0.1, 0.4);
  ASSERT_GT(grid.open_count(), 0u);
  // Both rooms are one component through the 1.2 m door (needs 0.8 m + cells).
  EXPECT_EQ(grid.component_count(), 1);
  for (const Cell c : grid.component_cells(0)) {
    const Point2 p = grid.centre_of(c);
    // Any point of an open cell, e.g. its corners, keeps the clearance.
    for (double ox : {-0.049, 0.049}) {
      for (double oy : {-0.049, 0.049}) {
        ASSERT_GE(testing::distance_to_non_free(world, p.x + ox, p.y + oy), 0.4 - 1e-9);
      }
    }
  }
  const Cell left = grid.cell_at({1.5, 3.5}), right = grid.cell_at({7.5, 3.5});
  const auto path = grid.plan(left, right);
  ASSERT_TRUE(path.has_value());
  ASSERT_FALSE(path->empty());
  EXPECT_NEAR(path->back().x, grid.centre_of(right).x, 1e-9);
  Point2 prev = grid.centre_of(left);
  double length = 0.0;
  for (const Point2& p : *path) {
    EXPECT_TRUE(grid.line_of_sight(prev, p));
    length += std::hypot(p.x - prev.x, p.y - prev.y);
    prev = p;
  }
  // Straight through the door (y = 2.9..4.1 m): about 6 m, far less than around anything.
  EXPECT_LT(length, 6.5);
  // A wider door requirement closes it: two components.
  const PlanGrid narrow(world, 0.1, 0.7);
  EXPECT_GE(narrow.component_count(), 2);
  EXPECT_FALSE(narrow.plan(narrow.cell_at({1.5, 3.5}), narrow.cell_at({7.5, 3.5})).has_value());
}

TEST(Robot, EveryTruePoseKeepsTheClearanceAndGoalsAreReached) {
  const World world(testing::two_rooms());
  MotionConfig motion;  // 0.5 m/s, 60 deg/s, clearance 0.35
  const PlanGrid grid = make_plan_grid(world, motion);
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    Robot robot("r", world, grid, motion, OdometryConfig{}, seed);
    bool visited_left = false, visited_right = false;
    const double dt = 0.02;            // one controller sub-step per call
    for (int i = 0; i < 30000; ++i) {  // 600 s
      const Pose2 before = robot.truth();
      robot.step(dt);
      const Pose2& now = robot.truth();
      const double moved = std::hypot(now.x - before.x, now.y - before.y);
      ASSERT_LE(moved, motion.speed * dt + 1e-9) << "seed " << seed << " step " << i;
      ASSERT_LE(std::abs(normalize_angle(now.theta - before.theta)),
                deg_to_rad(motion.turn_rate_deg) * dt + 1e-9);
      ASSERT_LE(robot.speed(), motion.speed + 1e-12);
      if (i % 10 == 0) {  // the brute-force check is slow; every 0.2 s is dense enough
        ASSERT_GE(testing::distance_to_non_free(world, now.x, now.y), motion.clearance)
            << "seed " << seed << " step " << i << " at " << now.x << ", " << now.y;
      }
      ASSERT_TRUE(world.drivable(now.x, now.y, motion.clearance));
      (now.x < 4.45 ? visited_left : visited_right) = true;
    }
    // 600 s at up to 0.5 m/s between random goals in a 7 m x 5.9 m space: many goals.
    EXPECT_GE(robot.goals_reached(), 25u) << "seed " << seed;
    EXPECT_GT(robot.distance(), 100.0);
    EXPECT_TRUE(visited_left && visited_right) << "never went through the door";
    EXPECT_EQ(robot.planning_failures(), 0u);
    // The controller keeps to the planned segments; the safety net is a rare exception.
    EXPECT_LE(robot.blocked_steps(), 10u) << "seed " << seed;
  }
}

TEST(Robot, ReachesFullSpeedAndTurnRateAndTurnsInPlace) {
  const World world(testing::two_rooms());
  MotionConfig motion;
  motion.speed = 0.8;
  motion.turn_rate_deg = 45.0;
  const PlanGrid grid = make_plan_grid(world, motion);
  Robot robot("r", world, grid, motion, OdometryConfig{}, 5);
  double max_v = 0.0, max_w = 0.0;
  int turning_in_place = 0;
  for (int i = 0; i < 10000; ++i) {
    robot.step(0.02);
    max_v = std::max(max_v, robot.speed());
    max_w = std::max(max_w, std::abs(robot.turn_rate()));
    if (robot.speed() == 0.0 && robot.turn_rate() != 0.0) ++turning_in_place;
  }
  // Full speed needs a heading error of exactly 0; it comes within 1 %.
  EXPECT_GT(max_v, 0.79);
  EXPECT_LE(max_v, 0.8);
  EXPECT_NEAR(max_w, deg_to_rad(45.0), 1e-9);
  EXPECT_GT(turning_in_place, 0);
}

TEST(Robot, ZeroNoiseOdometryIncrementsEqualTheTruth) {
  const World world(testing::two_rooms());
  const MotionConfig motion;
  const PlanGrid grid = make_plan_grid(world, motion);
  Robot robot("r", world, grid, motion, OdometryConfig{0.0, 0.0, 0.0}, 3);
  EXPECT_EQ(robot.odometry(), Pose2{});  // the odometry frame starts at 0
  for (int i = 0; i < 1000; ++i) {
    const Pose2 truth0 = robot.truth(), odom0 = robot.odometry();
    robot.step(0.2);
    const Pose2 dt = robot.truth().relative_to(truth0);
    const Pose2 dodom = robot.odometry().relative_to(odom0);
    ASSERT_NEAR(dodom.x, dt.x, 1e-9);
    ASSERT_NEAR(dodom.y, dt.y, 1e-9);
    ASSERT_NEAR(normalize_angle(dodom.theta - dt.theta), 0.0, 1e-9);
  }
}

TEST(Robot, OdometryNoiseGrowsWithTheMotionAndIsSeeded) {
  const World world(testing::two_rooms());
  const MotionConfig motion;
  const PlanGrid grid = make_plan_grid(world, motion);
  OdometryConfig noisy{0.05, 0.05, 0.02};
  // Per tick, the increment errors have sigma noise * motion: collect normalised errors.
  Robot robot("r", world, grid, motion, noisy, 9);
  double sum2 = 0.0;
  int n = 0;
  for (int i = 0; i < 3000; ++i) {
    const Pose2 truth0 = robot.truth(), odom0 = robot.odometry();
    robot.step(0.2);
    const Pose2 dt = robot.truth().relative_to(truth0);
    const Pose2 dodom = robot.odometry().relative_to(odom0);
    const double d = std::hypot(dt.x, dt.y);
    if (d < 0.05) {
      if (d == 0.0) {
        ASSERT_NEAR(dodom.x, dt.x, 1e-12);  // no motion, no noise in x
      }
      continue;
    }
    const double e = (dodom.x - dt.x) / (noisy.noise_xy * d);
    sum2 += e * e;
    ++n;
  }
  ASSERT_GT(n, 500);
  EXPECT_NEAR(std::sqrt(sum2 / n), 1.0, 0.1);  // unit variance once normalised

  Robot a("r", world, grid, motion, noisy, 11), b("r", world, grid, motion, noisy, 11);
  for (int i = 0; i < 200; ++i) {
    a.step(0.2);
    b.step(0.2);
  }
  EXPECT_EQ(a.truth(), b.truth());
  EXPECT_EQ(a.odometry(), b.odometry());
}

TEST(Fleet, SameSeedSameRunStampsFollowTheRate) {
  const World world(testing::two_rooms());
  FleetConfig c;
  c.robots = 3;
  c.seed = 4;
  c.rate = 5.0;
  c.start_stamp = 1000.0;
  Fleet a(world, c), b(world, c);
  for (int k = 1; k <= 50; ++k) {
    const auto sa = a.tick();
    const auto& sb = b.tick();
    ASSERT_EQ(sa.size(), 3u);
    for (std::size_t i = 0; i < sa.size(); ++i) {
      EXPECT_EQ(sa[i].truth.stamp, 1000.0 + k / 5.0);
      EXPECT_EQ(sa[i].scan.stamp, sa[i].truth.stamp);
      EXPECT_EQ(sa[i].truth.pose, sb[i].truth.pose);
      EXPECT_EQ(sa[i].scan.ranges, sb[i].scan.ranges);
      ASSERT_TRUE(sa[i].scan.odometry.has_value());
    }
  }
  EXPECT_EQ(a.robots()[0].id(), "robot-1");
  EXPECT_EQ(a.robots()[2].id(), "robot-3");
  // Another seed, other starts.
  c.seed = 5;
  const Fleet other(world, c);
  EXPECT_NE(other.robots()[0].truth(), Fleet(world, a.config()).robots()[0].truth());
}

TEST(Fleet, NoDrivableSpaceIsAnError) {
  const World world(testing::square_room(10));  // 0.4 m inside: no room for 0.35 m clearance
  try {
    Fleet fleet(world, FleetConfig{});
    FAIL() << "accepted a world without drivable space";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no drivable space"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace esfleet::sim
