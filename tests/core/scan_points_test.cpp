// Preparing a scan for matching: which beams become end points, which count as no-returns, and
// where the end points lie in the sensor frame.

#include "esfleet/core/scan_points.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

namespace esfleet {
namespace {

LaserScan scan_of(std::vector<float> ranges, float angle_min = 0.0f, float increment = 0.5f) {
  LaserScan s;
  s.angle_min = angle_min;
  s.angle_increment = increment;
  s.max_range = 30.0f;
  s.ranges = std::move(ranges);
  return s;
}

TEST(PrepareScan, EndPointsLieAlongTheirBeamsInTheSensorFrame) {
  const float pi = std::numbers::pi_v<float>;
  const ScanPoints p = prepare_scan(scan_of({2.0f, 3.0f, 4.0f}, -pi / 2, pi / 2));
  ASSERT_EQ(p.size(), 3u);
  EXPECT_NEAR(p.x[0], 0.0f, 1e-6f);  // -90 deg: to the right (y negative)
  EXPECT_NEAR(p.y[0], -2.0f, 1e-6f);
  EXPECT_NEAR(p.x[1], 3.0f, 1e-6f);  // straight ahead
  EXPECT_NEAR(p.y[1], 0.0f, 1e-6f);
  EXPECT_NEAR(p.x[2], 0.0f, 1e-6f);  // +90 deg: to the left
  EXPECT_NEAR(p.y[2], 4.0f, 1e-6f);
  EXPECT_EQ(p.range, (std::vector<float>{2.0f, 3.0f, 4.0f}));
  EXPECT_TRUE(p.no_return_angles.empty());
}

TEST(PrepareScan, ReadingsAtTheSensorMaximumAreNoReturnsWithTheirDirection) {
  const ScanPoints p = prepare_scan(scan_of({1.0f, 30.0f, 45.0f, 2.0f}, 0.1f, 0.5f));
  EXPECT_EQ(p.size(), 2u);
  ASSERT_EQ(p.no_return_angles.size(), 2u);
  EXPECT_FLOAT_EQ(p.no_return_angles[0], 0.6f);
  EXPECT_FLOAT_EQ(p.no_return_angles[1], 1.1f);
}

TEST(PrepareScan, MinAndMaxRangeDropBeamsWithoutMakingThemNoReturns) {
  const ScanPoints p = prepare_scan(scan_of({0.05f, 0.5f, 10.0f, 20.0f, 30.0f}), 0.1f, 15.0f);
  EXPECT_EQ(p.range, (std::vector<float>{0.5f, 10.0f}));
  EXPECT_EQ(p.no_return_angles.size(), 1u);  // only the sensor's own no-return
  // A max_range above the sensor's changes nothing; 0 means no extra limit.
  EXPECT_EQ(prepare_scan(scan_of({29.0f}), 0.0f, 100.0f).size(), 1u);
  EXPECT_EQ(prepare_scan(scan_of({29.0f}), 0.0f, 0.0f).size(), 1u);
}

TEST(PrepareScan, NonFiniteAndNegativeReadingsAreDropped) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const ScanPoints p = prepare_scan(scan_of({nan, -1.0f, inf, 3.0f, -inf}));
  EXPECT_EQ(p.range, (std::vector<float>{3.0f}));
  EXPECT_TRUE(p.no_return_angles.empty());  // an infinite reading is not trusted as one
}

}  // namespace
}  // namespace esfleet
