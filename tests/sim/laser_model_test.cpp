// The simulated laser: exact ranges in a synthetic square room, no-returns, and the statistics
// of dropout and range noise under a seeded generator.

#include "esfleet/sim/laser_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "sim_test_world.hpp"

namespace esfleet::sim {
namespace {

using testing::fill;
using testing::square_room;

/// Distance from (x, y) along `angle` to the inner faces of the square room of n cells of
/// `res` (walls one cell thick: the free space spans [res, (n - 1) res] on both axes).
double room_range(int n, double res, double x, double y, double angle) {
  const double lo = res, hi = (n - 1) * res;
  const double dx = std::cos(angle), dy = std::sin(angle);
  double t = std::numeric_limits<double>::infinity();
  if (dx > 1e-12) t = std::min(t, (hi - x) / dx);
  if (dx < -1e-12) t = std::min(t, (lo - x) / dx);
  if (dy > 1e-12) t = std::min(t, (hi - y) / dy);
  if (dy < -1e-12) t = std::min(t, (lo - y) / dy);
  return t;
}

TEST(CastRay, MeasuresTheWallFacesOfASquareRoomExactly) {
  const World world(square_room(100));  // 5 m, free from 0.05 to 4.95
  const double x = 1.83, y = 2.41;      // not on a cell centre
  for (int k = 0; k < 360; ++k) {
    const double angle = deg_to_rad(k + 0.37);
    const double expected = room_range(100, 0.05, x, y, angle);
    EXPECT_NEAR(cast_ray(world, x, y, angle, 30.0), expected, 1e-9) << "angle " << k;
  }
  // Axis-aligned beams, where one step delta is infinite.
  EXPECT_NEAR(cast_ray(world, x, y, 0.0, 30.0), 4.95 - x, 1e-9);
  EXPECT_NEAR(cast_ray(world, x, y, std::numbers::pi / 2, 30.0), 4.95 - y, 1e-9);
  EXPECT_NEAR(cast_ray(world, x, y, std::numbers::pi, 30.0), x - 0.05, 1e-9);
  EXPECT_NEAR(cast_ray(world, x, y, -std::numbers::pi / 2, 30.0), y - 0.05, 1e-9);
}

TEST(CastRay, NoReturnBeyondMaxRangeAndThroughUnknownSpace) {
  OccupancyImage img = square_room(100);
  EXPECT_EQ(cast_ray(World(img), 2.5, 2.5, 0.0, 1.0), 1.0);  // wall at 2.45 m > 1 m
  // An opening in the east wall leading into unknown space: the ray passes the unknown cells
  // and leaves the image without a return.
  fill(img, 99, 40, 100, 60, -1);
  const World open(img);
  EXPECT_EQ(cast_ray(open, 2.5, 2.5, 0.0, 30.0), 30.0);
  // An occupied cell beyond unknown cells is still seen.
  OccupancyImage img2 = testing::blank_image(100, 20, -1);
  fill(img2, 80, 0, 81, 20, 100);
  EXPECT_NEAR(cast_ray(World(img2), 0.52, 0.5, 0.0, 30.0), 4.0 - 0.52, 1e-9);
  // Starting inside an occupied cell.
  EXPECT_EQ(cast_ray(World(img2), 4.02, 0.5, 0.0, 30.0), 0.0);
}

TEST(SimulateScan, LayoutAndExactRangesWithoutNoise) {
  const World world(square_room(100));
  LaserConfig c;
  c.range_noise = 0.0;
  c.dropout = 0.0;
  c.max_range = 3.0;
  Rng rng(1);
  const Pose2 pose{2.0, 2.2, deg_to_rad(30.0)};
  const LaserScan scan = simulate_scan(world, c, pose, 12.5, rng);
  ASSERT_EQ(scan.ranges.size(), 181u);
  EXPECT_EQ(scan.stamp, 12.5);
  EXPECT_FLOAT_EQ(scan.angle_min, static_cast<float>(-std::numbers::pi / 2));
  EXPECT_FLOAT_EQ(scan.angle_increment, static_cast<float>(deg_to_rad(1.0)));
  EXPECT_EQ(scan.max_range, 3.0f);
  int no_returns = 0;
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    const double expected =
        room_range(100, 0.05, pose.x, pose.y, pose.theta + static_cast<double>(scan.angle(i)));
    if (expected >= 3.0) {
      EXPECT_TRUE(scan.is_no_return(i)) << i;
      ++no_returns;
    } else {
      EXPECT_NEAR(scan.ranges[i], expected, 1e-5) << i;  // float precision
      EXPECT_FALSE(scan.is_no_return(i));
    }
  }
  EXPECT_GT(no_returns, 0);  // the far corner lies beyond 3 m
}

TEST(SimulateScan, DropoutAndNoiseStatistics) {
  const World world(square_room(100));
  LaserConfig c;
  c.beams = 1000;
  c.fov_deg = 360.0;
  c.range_noise = 0.05;
  c.dropout = 0.2;
  Rng rng(42);
  const Pose2 pose{2.5, 2.5, 0.0};
  int dropped = 0, hits = 0;
  double sum = 0.0, sum2 = 0.0;
  for (int s = 0; s < 20; ++s) {
    const LaserScan scan = simulate_scan(world, c, pose, 0.0, rng);
    for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
      if (scan.is_no_return(i)) {
        ++dropped;  // every beam of this room has a return within 30 m
        continue;
      }
      const double err = scan.ranges[i] -
                         room_range(100, 0.05, pose.x, pose.y, static_cast<double>(scan.angle(i)));
      sum += err;
      sum2 += err * err;
      ++hits;
    }
  }
  const double n = 20000.0;
  // Binomial(20000, 0.2): sigma of the fraction 0.0028.
  EXPECT_NEAR(dropped / n, 0.2, 0.012);
  const double mean = sum / hits, sd = std::sqrt(sum2 / hits - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.003);  // sigma of the mean 0.05 / sqrt(16000) = 0.0004
  EXPECT_NEAR(sd, 0.05, 0.002);

  // Same seed, same scan.
  Rng a(7), b(7);
  EXPECT_EQ(simulate_scan(world, c, pose, 0.0, a).ranges,
            simulate_scan(world, c, pose, 0.0, b).ranges);
}

TEST(LaserConfig, ValidateNamesTheFlag) {
  auto message = [](LaserConfig c) {
    try {
      c.validate();
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  LaserConfig c;
  EXPECT_EQ(message(c), "");
  c.beams = 1;
  EXPECT_NE(message(c).find("--beams"), std::string::npos);
  c = {};
  c.fov_deg = 400;
  EXPECT_NE(message(c).find("--fov"), std::string::npos);
  c = {};
  c.max_range = 100;
  EXPECT_NE(message(c).find("--max-range"), std::string::npos);
  c = {};
  c.dropout = 1.5;
  EXPECT_NE(message(c).find("--dropout"), std::string::npos);
  c = {};
  c.range_noise = -1;
  EXPECT_NE(message(c).find("--range-noise"), std::string::npos);
}

}  // namespace
}  // namespace esfleet::sim
